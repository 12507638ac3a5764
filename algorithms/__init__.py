"""Built-in algorithms. Importing this package registers each of them."""

from algorithms import expert, random  # noqa: F401
