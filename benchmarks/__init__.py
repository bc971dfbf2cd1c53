"""What a developer runs to measure: one benchmark per question, each writing its numbers to JSON.

Run from the repository root, e.g. ``python -m benchmarks.bench_farm``; the
docs quote the files they write under ``results/``. :mod:`.common` holds what
they share (launching workers on several rank counts, the large-grid scene).
"""
