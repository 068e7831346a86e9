"""Hydra configuration of the AAM-Gym experiment runner (YAML files; a package so Hydra finds it)."""
