"""The optimizers (TRPO, SAC) and their parts. Imports nothing of the rest of bench."""
