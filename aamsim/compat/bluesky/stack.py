"""BlueSky's ``bluesky.stack``: stack command lines now, run them at the next ``bs.sim.step()``.

``stack("DT 5;FF", "HDG KL001 90")`` queues each ``;``-separated command, as
BlueSky's does; :func:`process` runs what is queued at once (``sim.step()``
calls it first). Commands run on aamsim's command stack, which reads BlueSky's
scenario language (``aamsim commands`` lists them). What a command reports goes
to BlueSky's echo: ``bs.net.send('ECHO', {'text', 'flags'})``, which a detached
node drops; a command that fails is also given as a
:class:`~aamsim.compat.bluesky._session.StackWarning` and logged, so that it is
never silent. The caller's code keeps running either way.
"""

from __future__ import annotations

from typing import Any, NoReturn

from aamsim.compat.bluesky._errors import not_provided
from aamsim.compat.bluesky._session import StackWarning
from aamsim.compat.bluesky._state import PROCESS, current_session

__all__ = ["StackWarning", "echo", "get_scenname", "process", "sender", "stack"]


def stack(*cmdlines: str, sender_id: Any = None) -> None:
    """Queue command lines (``;`` separates commands within one) for the next step."""
    if sender_id is not None:
        raise not_provided("bluesky.stack.stack(sender_id=...)", "there are no network clients")
    for cmdline in cmdlines:
        cmdline = cmdline.strip()
        if cmdline:
            PROCESS.pending.extend(cmdline.split(";"))


def process(ext_cmds: Any = None) -> None:
    """Run the queued commands now (or the commands of ``ext_cmds``, a string or a list of lines)."""
    session = current_session("bluesky.stack.process")
    if ext_cmds is None:
        session.process()
    elif isinstance(ext_cmds, str):
        session.process(ext_cmds.split(";"))
    else:
        session.process([line if isinstance(line, str) else line[0] for line in ext_cmds])


def echo(text: str = "", flags: int = 0) -> None:
    """Send text to BlueSky's echo (see the module docstring)."""
    current_session("bluesky.stack.echo").echo(text, flags)


def sender() -> None:
    """The client that sent the command being run: none (there is no network)."""
    return


def get_scenname() -> str:
    """Name of the scenario (SCEN's, or the file's)."""
    return current_session("bluesky.stack.get_scenname").simulation.scenario_name


def __getattr__(name: str) -> NoReturn:
    if name.startswith("__"):
        raise AttributeError(name)
    hints = {"command": "BlueSky plugins' commands; aamsim's plugins are written as in docs/plugins.md",
             "commandgroup": "as command", "get_scendata": "the scenario's commands are aamsim's queue",
             "set_scendata": "as get_scendata", "forward": "there are no network clients",
             "simstack": "", "Stack": ""}
    raise not_provided(f"bluesky.stack.{name}", hints.get(name, ""))
