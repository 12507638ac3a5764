"""Built-in algorithms, one module each. The registry imports them through the entry-point
group `ifo_bench.algorithms` (pyproject.toml), as it does any plugin."""
