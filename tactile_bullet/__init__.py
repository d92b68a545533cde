"""tactile-bullet: in-hand tactile shape recognition with a simulated Shadow hand."""

__version__ = "0.1.0"
