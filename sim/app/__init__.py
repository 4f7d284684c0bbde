"""The app layer: command line, CI gate, demo, benchmarks, consistency (Monte Carlo), validation tools."""
