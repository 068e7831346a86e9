"""``python -m rlbridge.experiment train|evaluate|report ...`` (the same as ``aamgym``)."""

from rlbridge.experiment.cli import main

if __name__ == "__main__":
    main()
