"""The workspace: run stages as Parquet, indexed in DuckDB (edge).

Only this package imports duckdb.
"""
