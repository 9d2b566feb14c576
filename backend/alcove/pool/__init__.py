"""Data-pool versions: datasets stored once by content hash, immutable pool versions
(version k = version k-1 + the datasets of iteration k, each at most once)."""
