"""Edges: readers and writers of files (Parquet, CSV, xlsx, YAML dumps)."""
