"""The workspace: run stages as Parquet, indexed in DuckDB (edge, issue 3).

Only this package imports duckdb.
"""
