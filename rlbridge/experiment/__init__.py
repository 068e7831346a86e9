"""The AAM-Gym experiment runner: ``aamgym train | evaluate | report`` (Hydra configuration)."""
