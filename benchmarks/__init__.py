"""benchmarks: the harness - references, sweeps, metrics, timing, gate, results store, CLI."""
