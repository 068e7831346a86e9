"""uamtoolkit_import: UAMToolkit flight schedules -> BlueSky/aamsim scenarios (``uam2scn``).

Modules: :mod:`network` (the vertiport network model and its routes),
:mod:`netfile` (network files, the shipped New York network), :mod:`headers`
and :mod:`schedule` (the schedule CSV contract), :mod:`convert` (schedule ->
scenario text), :mod:`demand`, :mod:`lanes` and :mod:`synth` (a synthetic
UAMToolkit), :mod:`scenarios` (the shipped New York scenarios),
:mod:`figures` (traffic maps), :mod:`cli` (``uam2scn``).
"""
