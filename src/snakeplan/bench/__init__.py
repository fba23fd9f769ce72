"""Benchmarks: kernel speed and the papers' tables, run through `snakeplan bench`."""
