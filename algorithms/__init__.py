"""Built-in algorithms. Importing this package registers each of them."""

from algorithms import bco, expert, gaifo, gail, random, survival, tcn  # noqa: F401
