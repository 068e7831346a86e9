"""Gradient steps for a GPU: captured once and replayed, inputs moved once per update.

On a GPU the learners' eager gradient steps are bound by Python and kernel launches, not by
arithmetic: one update of D2MAV-A launches hundreds of small kernels per gradient step (about
7 us each), Adam steps every parameter tensor on its own, and a host read per step waits for
the device (issue 27 measured the GPU busy 18-19 % of an update on an H200). This module holds
what the learners' *static* path needs to avoid that:

* :func:`host_to_device` moves an array with one copy, through pinned memory and asynchronously
  on CUDA (the learners move each update's observations once, then index them on the device);
* :class:`CapturedStep` runs a step function whose inputs and outputs live in tensors allocated
  once (fixed shapes and addresses): eagerly (the CPU, and the tests that compare it with the
  eager path), or recorded once into a CUDA graph and replayed, one launch for the forward and
  backward passes, the gradient clipping and the optimiser's step.

A captured step must not read anything on the host (no ``.item()``, no data-dependent shapes, no
``if`` on a tensor): the learners accumulate their losses in a device tensor read once per update.
"""

from __future__ import annotations

import contextlib
import logging
from collections.abc import Callable
from typing import Any

import numpy as np
import torch

log = logging.getLogger("rlbridge.capture")


def host_to_device(array: np.ndarray, device: torch.device) -> torch.Tensor:
    """``array`` as a tensor on ``device``: one copy, from pinned memory and asynchronous on CUDA.

    The pinned staging buffer comes from PyTorch's caching host allocator, which keeps it alive
    until the copy has run, so the caller may drop it at once.
    """
    t = torch.from_numpy(np.ascontiguousarray(array))
    if device.type == "cuda":
        return t.pin_memory().to(device, non_blocking=True)
    return t.to(device)


def copy_into(dst: torch.Tensor, src: np.ndarray, start: int = 0) -> None:
    """``dst[(start + k) % len(dst)] = src[k]``: at most two contiguous copies (a ring's wrap), from
    pinned memory and asynchronous on CUDA, into a tensor that keeps its address (a captured step's input)."""
    n, cap = len(src), dst.shape[0]
    if n > cap:
        raise ValueError(f"{n} rows do not fit a buffer of {cap}")
    first = min(n, cap - start)
    cuda = dst.device.type == "cuda"
    for lo, hi, at in ((0, first, start), (first, n, 0)):
        if hi > lo:
            part = torch.from_numpy(np.ascontiguousarray(src[lo:hi]))
            dst[at:at + hi - lo].copy_(part.pin_memory() if cuda else part, non_blocking=cuda)


def check_device(name: str) -> torch.device:
    """The PyTorch device ``name`` (``cpu``, ``cuda``, ``cuda:N``) names, or a ValueError saying why it
    cannot be used on this machine (raised before anything starts)."""
    try:
        dev = torch.device(name)
    except RuntimeError:
        raise ValueError(f"device={name}: not a device (one of cpu, cuda, cuda:N, auto)") from None
    if dev.type == "cuda":
        if not torch.cuda.is_available():
            why = "PyTorch was built without CUDA" if torch.version.cuda is None else "no CUDA device is visible"
            raise ValueError(f"device={name}: CUDA is not available on this machine ({why}; PyTorch "
                             f"{torch.__version__}); use device=cpu, or device=auto to take a GPU when there is one")
        if dev.index is not None and dev.index >= torch.cuda.device_count():
            raise ValueError(f"device={name}: this machine has {torch.cuda.device_count()} CUDA device(s)")
    elif dev.type != "cpu":
        raise ValueError(f"device={name}: the learners run on cpu or cuda")
    return dev


def static_optimizer(params: list[torch.nn.Parameter], device: torch.device, lr: float, eps: float
                     ) -> torch.optim.Adam:
    """Adam for the static path: fused and capturable on CUDA (one kernel for every parameter, the
    step counters on the device so that a graph can replay it); PyTorch's default elsewhere."""
    if device.type == "cuda":
        return torch.optim.Adam(params, lr=lr, eps=eps, fused=True, capturable=True)
    return torch.optim.Adam(params, lr=lr, eps=eps)


IMPLEMENTATION_KEYS = ("fused", "foreach", "capturable", "differentiable")


def load_optimizer_state(optimizer: torch.optim.Optimizer, state: dict[str, Any]) -> None:
    """``optimizer.load_state_dict(state)``, keeping how ``optimizer`` was built.

    PyTorch's loader takes the saved param groups' ``fused``/``capturable``/``foreach`` flags with
    the hyper-parameters, so a checkpoint of a GPU learner (fused, capturable Adam) would make a
    CPU learner's Adam capturable, and a CPU checkpoint would make a GPU learner's Adam refuse to
    be captured. The flags stay this optimizer's, and Adam's step counts move to where its
    implementation keeps them (the parameter's device when fused or capturable, else the CPU).
    """
    kept = [{k: g[k] for k in IMPLEMENTATION_KEYS if k in g} for g in optimizer.param_groups]
    optimizer.load_state_dict(state)
    for group, flags in zip(optimizer.param_groups, kept):
        group.update(flags)
        on_device = bool(group.get("fused") or group.get("capturable"))
        for p in group["params"]:
            st = optimizer.state.get(p, {})
            if torch.is_tensor(st.get("step")):
                st["step"] = st["step"].to(dtype=torch.float32, device=p.device if on_device else "cpu")


class CapturedStep:
    """A training step that reads and writes only static tensors, run eagerly or as a CUDA graph.

    Args:
        fn: the step: forward, loss, ``backward()``, gradient clipping and ``optimizer.step()``,
            reading its inputs from tensors whose shapes and addresses never change and writing
            what it reports into such tensors. It must not call ``zero_grad``: this class does.
        params: the parameters ``fn`` updates.
        optimizer: the optimiser ``fn`` steps (its state is restored after the capture's warm-up).
        capture: record a CUDA graph at the first call and replay it afterwards (CUDA only);
            False: call ``fn`` eagerly every time.
        warmup: eager runs on a side stream before the capture (CUDA's recipe: lets lazily
            initialised state, e.g. Adam's moments and cuBLAS workspaces, exist before recording).

    The warm-up runs are real steps: the parameters and the optimiser's state are saved before
    them and copied back after, so the first replay starts from the weights the eager step would
    have started from. Whatever else ``fn`` writes (e.g. a loss accumulator) the caller resets
    after :meth:`prepare`.
    """

    def __init__(self, fn: Callable[[], None], params: list[torch.nn.Parameter], optimizer: torch.optim.Optimizer,
                 capture: bool, warmup: int = 3):
        if capture and not torch.cuda.is_available():
            raise RuntimeError("a CUDA graph needs CUDA")
        self.fn = fn
        self.params = list(params)
        self.optimizer = optimizer
        self.capture = capture
        self.warmup = int(warmup)
        self.graph: Any = None  # torch.cuda.CUDAGraph once recorded

    def prepare(self) -> bool:
        """Record the graph now if it is to be recorded and is not yet; True if this call recorded it.

        Call it with valid inputs in the static tensors (the warm-up runs ``fn`` on them).
        """
        if not self.capture or self.graph is not None:
            return False
        self.warm_up()
        # Gradients allocated inside the capture live in the graph's memory pool: every replay
        # writes them afresh (no accumulation across steps), as zero_grad + backward would.
        self.optimizer.zero_grad(set_to_none=True)
        graph = torch.cuda.CUDAGraph()
        with torch.cuda.graph(graph):
            self.fn()
        self.graph = graph
        log.info("captured a gradient step in a CUDA graph (%d parameter tensors)", len(self.params))
        return True

    def warm_up(self) -> None:
        """``warmup`` eager steps (on a side stream on CUDA), then the parameters and the optimiser's
        state as they were before: a state the warm-up created is reset to a fresh one (zeros)."""
        saved_params = [p.detach().clone() for p in self.params]
        saved_state = {id(p): {k: (v.clone() if torch.is_tensor(v) else v) for k, v in s.items()}
                       for p, s in self.optimizer.state.items()}
        cuda = self.params[0].device.type == "cuda" if self.params else False
        stream = torch.cuda.Stream() if cuda else None
        if stream is not None:
            stream.wait_stream(torch.cuda.current_stream())
        with torch.cuda.stream(stream) if stream is not None else contextlib.nullcontext():
            for _ in range(self.warmup):
                self.optimizer.zero_grad(set_to_none=True)
                self.fn()
        if stream is not None:
            torch.cuda.current_stream().wait_stream(stream)
        with torch.no_grad():
            for param, value in zip(self.params, saved_params):
                param.copy_(value)
            for key, st in self.optimizer.state.items():
                old = saved_state.get(id(key))
                for k, v in st.items():
                    if not torch.is_tensor(v):
                        continue
                    if old is not None and k in old:
                        v.copy_(old[k])
                    else:
                        v.zero_()

    def __call__(self) -> None:
        """One step: a replay of the graph, or ``zero_grad`` and ``fn`` eagerly."""
        if self.capture:
            if self.graph is None:
                self.prepare()
            self.graph.replay()
            return
        self.optimizer.zero_grad(set_to_none=True)
        self.fn()
