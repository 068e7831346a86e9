"""``render_mode`` for the environments: ``"rgb_array"`` draws the traffic, ``"human"`` shows it in the web viewer.

``rgb_array``: :meth:`EnvRenderer.render` returns the picture of the current
traffic as an ``(height, width, 3)`` uint8 array, drawn by
:class:`aamsim.render.draw.TrafficPainter` (the web viewer's look), so
``gymnasium.wrappers.RecordVideo`` records episodes unchanged.

``human``: the first render starts :class:`aamsim.viewer.live.LiveViewer` on
loopback (``viewer_port``; 0 picks a free port) and prints its URL; as
Gymnasium expects of human mode, every ``reset`` and ``step`` then publishes
the traffic to it.

In-process episodes are drawn with their conflict states (in LoWC, in NMAC)
from the simulation's conflict service; over ZeroMQ or on BlueSky the
backend's ``traffic_state`` gives positions and speeds, so aircraft are
coloured normal or holding only.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np

RENDER_MODES = ("human", "rgb_array")
RENDER_FPS = 10


def check_render_mode(render_mode: str | None) -> str | None:
    if render_mode is not None and render_mode not in RENDER_MODES:
        raise ValueError(f"render_mode {render_mode!r} is not supported; choose one of {', '.join(RENDER_MODES)} "
                         "or None")
    return render_mode


class EnvRenderer:
    """Draws an environment's backend (an in-process :class:`~rlbridge.core.EpisodeCore` or a remote one)."""

    def __init__(self, core: Any, scenario_text: str, render_mode: str, size: tuple[int, int] = (640, 640),
                 viewer_port: int = 0) -> None:
        self.core = core
        self.scenario_text = scenario_text
        self.render_mode = render_mode
        self.size = size
        self.viewer_port = viewer_port
        self._painter: Any = None
        self._viewer: Any = None
        self._last_simt: float | None = None

    def frame(self) -> Any:
        from aamsim.viewer.frames import DEFAULT_HOLD_SPEED_MPS, TrafficFrame, airborne_status, frame_from_sim

        sim = getattr(self.core, "sim", None)
        if sim is not None:
            frame = frame_from_sim(sim, events_since=self._last_simt)
        else:
            st = self.core.traffic_state()
            tas = np.asarray(st["tas"], dtype=np.float64)
            airborne, status = airborne_status(np.asarray(st["alt"], dtype=np.float64), tas, DEFAULT_HOLD_SPEED_MPS)
            frame = TrafficFrame(float(st["simt"]), tuple(st["ids"]), np.asarray(st["lat"], dtype=np.float64),
                                 np.asarray(st["lon"], dtype=np.float64), np.asarray(st["alt"], dtype=np.float64),
                                 np.asarray(st["trk"], dtype=np.float64), tas, status,
                                 metrics={"airborne": int(np.count_nonzero(airborne))})
        self._last_simt = frame.simt
        return frame

    def _layout(self, frame: Any) -> Any:
        from aamsim.viewer.frames import layout_from_scenario

        return layout_from_scenario(self.scenario_text, frame.lat, frame.lon)

    def rgb_array(self) -> np.ndarray:
        frame = self.frame()
        if self._painter is None:
            from aamsim.render.draw import TrafficPainter

            path = getattr(self.core, "path", None)  # the local backend's scenario file: the picture's title
            self._painter = TrafficPainter(self._layout(frame), *self.size,
                                           title=Path(path).stem if path is not None else "")
        image: np.ndarray = self._painter.paint(frame)
        return image

    def show(self) -> None:
        """Human mode: publish the traffic now to the live viewer (started on the first call)."""
        frame = self.frame()
        if self._viewer is None:
            from aamsim.viewer.live import LiveViewer

            self._viewer = LiveViewer("127.0.0.1", self.viewer_port, title="aamgym episode")
            url = self._viewer.start()
            print(f"aamgym viewer: {url}", file=sys.stderr)
            self._viewer.publish(frame, self._layout(frame))
        else:
            self._viewer.publish(frame)

    @property
    def url(self) -> str | None:
        return None if self._viewer is None else self._viewer.url

    def close(self) -> None:
        if self._painter is not None:
            self._painter.close()
            self._painter = None
        if self._viewer is not None:
            self._viewer.close()
            self._viewer = None


def record_video(env: Any, video_folder: str | Path, **kwargs: Any) -> Any:
    """``gymnasium.wrappers.RecordVideo(env, video_folder, **kwargs)``, or one line naming the ``video`` extra.

    RecordVideo writes its MP4s with MoviePy, which the base install leaves out; without it,
    this raises :class:`aamsim.extras.MissingExtra` (Gymnasium's own message would send the user
    to ``gymnasium[other]``). ``env`` needs ``render_mode="rgb_array"``.
    """
    from aamsim.extras import require

    require("video", "gymnasium.wrappers.RecordVideo", ("moviepy",))
    from gymnasium.wrappers import RecordVideo

    return RecordVideo(env, str(video_folder), **kwargs)
