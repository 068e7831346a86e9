"""The RL bridge as an aamsim plugin (``BRIDGE``): ``aamsim serve`` finds the server here.

Loaded into a simulation (``PLUGINS LOAD BRIDGE``) it only adds the
``BRIDGE`` status command; :func:`serve` runs the ZeroMQ simulation server
(:mod:`rlbridge.server`) until SIGINT or SIGTERM.
"""

from __future__ import annotations

import logging
import signal
import threading
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from aamsim.stack.registry import command
from aamsim.stop_signals import StopSignals
from rlbridge.heap import use_one_arena
from rlbridge.protocol import DEFAULT_MAX_MESSAGE_BYTES, PROTOCOL_VERSION
from rlbridge.server import DEFAULT_BIND, ServerOptions, SimulationServer

if TYPE_CHECKING:
    from aamsim.simulation import Simulation

log = logging.getLogger(__name__)

__all__ = ["DEFAULT_BIND", "DEFAULT_MAX_MESSAGE_BYTES", "init_plugin", "serve"]


def init_plugin(sim: Simulation) -> None:
    """Register ``BRIDGE`` (status); nothing else changes in the simulation."""

    @command("BRIDGE", group="simulation")
    def bridge(sim: Simulation) -> str:
        """BRIDGE: status of the RL bridge (protocol version; how to serve this simulator over ZeroMQ)."""
        return (f"rlbridge: ZeroMQ protocol v{PROTOCOL_VERSION}; serve simulations with "
                f"`aamsim serve --bind {DEFAULT_BIND}`")

    sim.commands.add(bridge)


def serve(bind: str = DEFAULT_BIND, plugins: tuple[str, ...] = (),
          on_ready: Callable[[str], None] | None = None, **options: Any) -> int:
    """Run the simulation server until SIGINT/SIGTERM (or an enabled shutdown request); returns 0.

    ``options`` are :class:`~rlbridge.server.ServerOptions` fields;
    ``on_ready(endpoint)`` is called once the socket is bound. Called in the
    main thread, the server owns the process: it handles the stop signals, and
    all its threads allocate from one heap, whose freed memory it gives back
    (:func:`rlbridge.heap.use_one_arena`, before ZeroMQ starts its I/O thread).
    """
    owns_process = threading.current_thread() is threading.main_thread()
    if owns_process:
        use_one_arena()
    server = SimulationServer(ServerOptions(bind=bind, plugins=tuple(plugins), **options))
    with StopSignals(lambda num, frame: _stop(server, num)):  # main thread only: none elsewhere
        try:
            if on_ready is not None:
                on_ready(server.endpoint)
            server.serve_forever()
        finally:
            server.close()
    return 0


def _stop(server: SimulationServer, signum: int) -> None:
    log.info("%s received: stopping", signal.Signals(signum).name)
    server.stop_from_signal()  # a request under way is abandoned with an error reply
