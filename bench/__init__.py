"""ifo-bench: a benchmark harness for imitation from observation."""

__version__ = "0.1.0"
