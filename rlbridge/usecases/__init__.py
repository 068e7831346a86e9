"""AAM use cases; ``corridor_sa`` is the paper's separation assurance in corridors (docs/usecases.md)."""

from rlbridge.usecases.protocol import Feedback, Observations, UseCase, UseCaseBase
from rlbridge.usecases.registry import available, env_id, make_usecase, usecase_spec
from rlbridge.usecases.spec import CapabilityError, Needs, UseCaseSpec

__all__ = ["CapabilityError", "Feedback", "Needs", "Observations", "UseCase", "UseCaseBase", "UseCaseSpec", "available",
           "env_id", "make_usecase", "usecase_spec"]
