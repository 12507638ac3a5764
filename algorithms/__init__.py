"""Built-in algorithms. Importing this package registers each of them."""

from algorithms import expert, gaifo, gail, random, survival  # noqa: F401
