"""AAM use cases; ``corridor_sa`` is the paper's separation assurance in corridors."""

from rlbridge.usecases.registry import Observations, UseCase, available, make_usecase

__all__ = ["Observations", "UseCase", "available", "make_usecase"]
