"""Videos of runs: a run directory replayed into an MP4 (imageio-ffmpeg's own ffmpeg) or a GIF.

Frame ``k`` shows sim time ``t_from + k * speed / fps``: at ``speed`` 60 and
10 frames per second, one second of video is one minute of traffic. Trails
show the last 30 s of each aircraft; events ring where they began.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np

from aamsim.extras import require
from aamsim.render.draw import TrafficPainter
from aamsim.viewer.frames import RunReplay

VIDEO_SUFFIXES = (".mp4", ".gif")
MAX_FRAMES = 100_000


def frame_times(t_start: float, t_end: float, t_from: float | None, t_to: float | None, speed: float,
                fps: float) -> np.ndarray:
    """The sim times of the video's frames; raises ``ValueError`` naming the bad option."""
    if not speed > 0 or not np.isfinite(speed):
        raise ValueError(f"--speed must be a positive number of sim seconds per video second, not {speed}")
    if not 1 <= fps <= 60:
        raise ValueError(f"--fps must be between 1 and 60, not {fps}")
    a = t_start if t_from is None else float(t_from)
    b = t_end if t_to is None else float(t_to)
    if not (np.isfinite(a) and np.isfinite(b)) or b <= a:
        raise ValueError(f"--from {a:g} s must come before --to {b:g} s")
    if a > t_end or b < t_start:
        raise ValueError(f"--from/--to {a:g}-{b:g} s lie outside the run ({t_start:g}-{t_end:g} s)")
    step = speed / fps
    n = int(np.floor((b - a) / step + 1e-9)) + 1
    if n > MAX_FRAMES:
        raise ValueError(f"{n} frames is too long a video; raise --speed or shorten --from/--to")
    return a + step * np.arange(n)


def write_run_video(run_dir: str | Path, out_path: str | Path, *, t_from: float | None = None,
                    t_to: float | None = None, speed: float = 60.0, fps: float = 10.0, width: int = 800,
                    height: int = 800, progress: bool = True) -> int:
    """Replay ``run_dir`` into ``out_path`` (``.mp4`` or ``.gif``); returns the number of frames."""
    return write_runs_video([("", run_dir)], out_path, t_from=t_from, t_to=t_to, speed=speed, fps=fps,
                            width=width, height=height, progress=progress)


def write_runs_video(panels: list[tuple[str, str | Path]], out_path: str | Path, *, t_from: float | None = None,
                     t_to: float | None = None, speed: float = 60.0, fps: float = 10.0, width: int = 800,
                     height: int = 800, progress: bool = True) -> int:
    """Several runs side by side at the same sim times (``panels``: label and run directory each).

    Every panel shows the first run's map, widened to every run's traffic, so positions line up;
    ``width`` is one panel's. Returns the number of frames.
    """
    import imageio.v2 as imageio

    from aamsim.viewer.frames import MapLayout

    out = Path(out_path)
    if out.suffix.lower() not in VIDEO_SUFFIXES:
        raise ValueError(f"{out}: the video must end in {' or '.join(VIDEO_SUFFIXES)}")
    if out.suffix.lower() == ".mp4":  # imageio writes MP4 with imageio-ffmpeg's ffmpeg; GIF needs only pillow
        require("video", f"an MP4 video ({out.name})", ("imageio_ffmpeg",), hint="or write a .gif")
    if not panels:
        raise ValueError("no run to draw")
    replays = [RunReplay(d) for _, d in panels]
    for r in replays:
        if not len(r.times):
            raise ValueError(f"{r.run_dir}: no trajectory samples to draw (no aircraft flew)")
    times = frame_times(min(r.t_start for r in replays), max(r.t_end for r in replays), t_from, t_to, speed, fps)
    first = replays[0].layout()
    boxes = np.array([r.layout().bounds for r in replays])
    layout = MapLayout(first.vertiports, first.routes, first.outline,
                       (boxes[:, 0].min(), boxes[:, 1].max(), boxes[:, 2].min(), boxes[:, 3].max()))
    painters = [TrafficPainter(layout, width, height, label or str(r.summary.get("scenario") or ""))
                for (label, _), r in zip(panels, replays)]
    kwargs: dict[str, Any] = {"fps": fps}
    if out.suffix.lower() == ".mp4":
        kwargs.update(codec="libx264", quality=7, macro_block_size=8, pixelformat="yuv420p")
    else:
        kwargs = {"duration": 1000.0 / fps, "loop": 0}
    from tqdm import tqdm

    previous: float | None = None
    with imageio.get_writer(out, **kwargs) as writer:
        for t in tqdm(times.tolist(), desc=out.name, unit="frame", disable=not progress, leave=False):
            images = [p.paint(r.frame_at(t, events_since=previous), r.trails(t, 30.0))
                      for p, r in zip(painters, replays)]
            writer.append_data(np.hstack(images) if len(images) > 1 else images[0])  # type: ignore[attr-defined]
            previous = t
        if progress and out.suffix.lower() != ".mp4":
            # Pillow encodes a GIF's frames only when the writer closes: say so, or the wait looks like a hang.
            print(f"encoding {out.name} ({len(times)} frames) ...", file=sys.stderr, flush=True)
    for p in painters:
        p.close()
    return len(times)
