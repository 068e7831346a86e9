"""AAM use cases; ``corridor_sa`` is the paper's separation assurance in corridors (docs/usecases.md)."""

from rlbridge.usecases.protocol import Feedback, Observations, UseCase, UseCaseBase
from rlbridge.usecases.registry import available, env_id, make_usecase

__all__ = ["Feedback", "Observations", "UseCase", "UseCaseBase", "available", "env_id", "make_usecase"]
