"""The harness: suites, trials, the runner and its records, the simulators, experts and
demonstrations, and the registry of algorithms. Imports rl and imitation, never analysis."""
