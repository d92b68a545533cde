"""What the torch-trained classifiers share: a lazy torch import, a checked device and a
memory budget checked before anything is allocated.

torch is imported only when training starts (it costs about a second, which the CLI and a
fitted model's predictions should not pay). A device or a model size the machine cannot serve
is the user's input, so both raise ``UsageError`` (exit status 2 in the CLI) before any work.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from ..errors import UsageError

MEMORY_LIMIT_BYTES = 2 * 1024**3
"""Largest estimated working memory (parameters, optimiser state, one training step's
activations, prediction temporaries) a torch-trained classifier may plan for: 2 GiB. Grasp
models need a few MB; a size beyond this is a typo (``depth=40`` is 2**40 leaves per tree),
refused with the estimate before anything is allocated."""


def import_torch() -> Any:
    """torch, imported on first use; a clear error when the ``torch`` extra is missing."""
    try:
        import torch
    except ImportError:
        raise UsageError(
            "this classifier trains with torch, which is not installed "
            "(pip install 'tactile-bullet[torch]')"
        ) from None
    return torch


def check_device_name(name: Any, who: str) -> None:
    """A device must be a non-empty string ("cpu", "cuda", "cuda:1", "mps"); no torch needed."""
    if not isinstance(name, str) or not name.strip():
        raise UsageError(f"{who} device must be a name such as 'cpu' or 'cuda', got {name!r}")


def torch_device(torch: Any, name: str, who: str) -> Any:
    """The torch device called ``name``, or UsageError when this build or machine lacks it."""
    check_device_name(name, who)
    try:
        device = torch.device(name)
    except (RuntimeError, ValueError):
        raise UsageError(f"{who} device {name!r} is not a torch device (cpu, cuda, mps)") from None
    if device.type == "cpu":
        return device
    if device.type == "cuda":
        if not torch.cuda.is_available():
            raise UsageError(
                f"{who} device {name!r}: this torch build or machine has no CUDA GPU "
                "(use device=cpu)"
            )
        count = torch.cuda.device_count()
        if device.index is not None and device.index >= count:
            raise UsageError(f"{who} device {name!r}: only {count} CUDA device(s) here")
        return device
    if device.type == "mps":
        if not torch.backends.mps.is_available():
            raise UsageError(f"{who} device {name!r}: MPS is not available here (use device=cpu)")
        return device
    raise UsageError(f"{who} device {name!r}: only cpu, cuda and mps are supported")


def human_bytes(n: float) -> str:
    """1536 -> '1.5 KiB'; up to EiB (a depth-60 forest)."""
    for unit in ("B", "KiB", "MiB", "GiB", "TiB", "PiB"):
        if n < 1024 or unit == "PiB":
            break
        n /= 1024
    if n >= 1024:
        return f"{n / 1024:.3g} EiB"
    return f"{n:.3g} {unit}"


def check_memory(estimate: float, who: str, what: str, limit: float = MEMORY_LIMIT_BYTES) -> None:
    """Refuse a model whose estimated working memory exceeds ``limit`` (before allocating)."""
    if estimate > limit:
        raise UsageError(
            f"{who} would need about {human_bytes(estimate)} ({what}); the limit is "
            f"{human_bytes(limit)}: choose a smaller model"
        )


@contextmanager
def torch_threads(torch: Any, threads: int | None) -> Iterator[None]:
    """Run with ``threads`` torch threads (None: unchanged), restoring the global setting."""
    previous = torch.get_num_threads()
    if threads is not None and threads != previous:
        torch.set_num_threads(threads)
    try:
        yield
    finally:
        if torch.get_num_threads() != previous:
            torch.set_num_threads(previous)
