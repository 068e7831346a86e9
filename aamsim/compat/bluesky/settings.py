"""BlueSky's ``bluesky.settings``: the configuration values, with BlueSky 1.1.1's defaults.

The shim reads ``simdt`` (the time step after a reset), ``asas_pzr`` and ``asas_pzh``
(the protected zone of ``traf.creconfs``) and ``casmach_threshold`` (speeds below
it are Mach numbers in the Python API). The other values are there so that code
reading them gets BlueSky's defaults; changing them has no effect
(docs/bluesky-api.md says which).
"""

from __future__ import annotations

from typing import Any

# BlueSky 1.1.1's defaults (its resources/default.cfg and the set_variable_defaults of its modules).
simdt = 0.05  # s
performance_dt = 1.0  # s
asas_dt = 1.0  # s
asas_pzr = 5.0  # NM
asas_pzh = 1000.0  # ft
asas_dtlookahead = 300.0  # s
asas_mar = 1.05
fms_dt = 10.5  # s
casmach_threshold = 2.0  # m/s: a speed below it (and above 0.1) is a Mach number
performance_model = "openap"
prefer_compiled = True
start_location = "EHAM"
scenario_path = "scenario"

# The values the shim reads; the others are kept for code that reads them.
READ_BY_SHIM = ("simdt", "asas_pzr", "asas_pzh", "casmach_threshold")


def set_variable_defaults(**kwargs: Any) -> None:
    """Give settings a value unless they have one (BlueSky's plugins declare theirs this way)."""
    for name, value in kwargs.items():
        globals().setdefault(name, value)


def init(cfgfile: str = "") -> None:
    """BlueSky reads its configuration file here; the shim keeps the defaults above.

    Raises:
        NotImplementedError: a configuration file was given (reading one is not provided).
    """
    if cfgfile:
        from aamsim.compat.bluesky._errors import not_provided

        raise not_provided("bluesky.settings.init(cfgfile)", "set the values as attributes of bluesky.settings")
