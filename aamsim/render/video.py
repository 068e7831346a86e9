"""Videos of runs: a run directory replayed into an MP4 (imageio-ffmpeg's own ffmpeg) or a GIF.

Frame ``k`` shows sim time ``t_from + k * speed / fps``: at ``speed`` 60 and
10 frames per second, one second of video is one minute of traffic. Trails
show the last 30 s of each aircraft; events ring where they began.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

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
    import imageio.v2 as imageio

    out = Path(out_path)
    if out.suffix.lower() not in VIDEO_SUFFIXES:
        raise ValueError(f"{out}: the video must end in {' or '.join(VIDEO_SUFFIXES)}")
    replay = RunReplay(run_dir)
    times = frame_times(replay.t_start, replay.t_end, t_from, t_to, speed, fps)
    painter = TrafficPainter(replay.layout(), width, height, str(replay.summary.get("scenario") or ""))
    kwargs: dict[str, Any] = {"fps": fps}
    if out.suffix.lower() == ".mp4":
        kwargs.update(codec="libx264", quality=7, macro_block_size=8, pixelformat="yuv420p")
    else:
        kwargs = {"duration": 1000.0 / fps, "loop": 0}
    from tqdm import tqdm

    previous: float | None = None
    with imageio.get_writer(out, **kwargs) as writer:
        for t in tqdm(times.tolist(), desc=out.name, unit="frame", disable=not progress, leave=False):
            frame = replay.frame_at(t, events_since=previous)
            writer.append_data(painter.paint(frame, replay.trails(t, 30.0)))  # type: ignore[attr-defined]
            previous = t
    painter.close()
    return len(times)
