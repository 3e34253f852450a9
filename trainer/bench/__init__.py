"""svbrdf-bench: run time against error on ground-truth sets and real photos."""
