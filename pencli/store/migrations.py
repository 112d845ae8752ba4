"""Numbered, transactional schema migrations of the workspace catalog.

Each migration is applied once, inside a transaction, and recorded in
``schema_migrations``.  Never edit a released migration: add a new one.
The tables are documented in ``schema/catalog.md``.
"""

from __future__ import annotations

MIGRATIONS: tuple[tuple[int, str, str], ...] = (
    (1, "runs, parameters and stages", """
        CREATE TABLE runs (
            run_id              VARCHAR PRIMARY KEY,
            content_sha256      VARCHAR NOT NULL UNIQUE,
            source              VARCHAR NOT NULL,
            source_format       VARCHAR NOT NULL,
            ingested_at         TIMESTAMP NOT NULL,
            run_date            DATE,
            operator            VARCHAR,
            notes               VARCHAR,
            tags                VARCHAR[],
            info                JSON,
            material            VARCHAR NOT NULL,
            penetrator          VARCHAR NOT NULL,
            energizing          VARCHAR NOT NULL,
            blade_thickness_mm  DOUBLE NOT NULL,
            blade_width_mm      DOUBLE NOT NULL,
            spring_count        INTEGER NOT NULL,
            sprung_mass_kg      DOUBLE NOT NULL,
            surface_offset_mm   DOUBLE NOT NULL,
            sampling_rate_hz    DOUBLE NOT NULL,
            n_samples           BIGINT NOT NULL,
            duration_s          DOUBLE NOT NULL,
            pen_version         VARCHAR NOT NULL
        );
        CREATE TABLE run_parameters (
            run_id      VARCHAR NOT NULL REFERENCES runs(run_id),
            kind        VARCHAR NOT NULL,
            name        VARCHAR NOT NULL,
            parameters  JSON NOT NULL,
            PRIMARY KEY (run_id, kind)
        );
        CREATE TABLE stages (
            run_id          VARCHAR NOT NULL REFERENCES runs(run_id),
            stage_no        INTEGER NOT NULL,
            stage           VARCHAR NOT NULL,
            parent_no       INTEGER,
            path            VARCHAR NOT NULL,
            content_sha256  VARCHAR NOT NULL,
            command         VARCHAR NOT NULL,
            parameters      JSON NOT NULL,
            pen_version     VARCHAR NOT NULL,
            created_at      TIMESTAMP NOT NULL,
            PRIMARY KEY (run_id, stage_no)
        );
    """),
    (2, "fitted material versions", """
        CREATE TABLE materials (
            material         VARCHAR NOT NULL,
            version          INTEGER NOT NULL,
            created_at       TIMESTAMP NOT NULL,
            mode             VARCHAR NOT NULL,
            terms            VARCHAR[] NOT NULL,
            coefficients     JSON NOT NULL,
            stderr           JSON NOT NULL,
            fit              JSON NOT NULL,
            source_runs      VARCHAR[] NOT NULL,
            ranges           JSON NOT NULL,
            material_file    JSON NOT NULL,
            model_data_path  VARCHAR,
            command          VARCHAR NOT NULL,
            pen_version      VARCHAR NOT NULL,
            PRIMARY KEY (material, version)
        );
    """),
    (3, "design-space sweeps", """
        CREATE TABLE sweeps (
            sweep_id     INTEGER PRIMARY KEY,
            created_at   TIMESTAMP NOT NULL,
            penetrator   VARCHAR NOT NULL,
            material     VARCHAR NOT NULL,
            energizing   VARCHAR NOT NULL,
            variables    JSON NOT NULL,
            n_designs    BIGINT NOT NULL,
            path         VARCHAR NOT NULL,
            command      VARCHAR NOT NULL,
            pen_version  VARCHAR NOT NULL
        );
    """),
    (4, "a run's geometry; blade dimensions only for blades", """
        -- DuckDB cannot drop a NOT NULL from a table others reference: the three run tables are rebuilt, their rows
        -- kept; every run before this migration is a blade
        CREATE TEMP TABLE keep_stages AS SELECT * FROM stages;
        CREATE TEMP TABLE keep_parameters AS SELECT * FROM run_parameters;
        CREATE TEMP TABLE keep_runs AS SELECT * FROM runs;
        DROP TABLE stages;
        DROP TABLE run_parameters;
        DROP TABLE runs;
        CREATE TABLE runs (
            run_id              VARCHAR PRIMARY KEY,
            content_sha256      VARCHAR NOT NULL UNIQUE,
            source              VARCHAR NOT NULL,
            source_format       VARCHAR NOT NULL,
            ingested_at         TIMESTAMP NOT NULL,
            run_date            DATE,
            operator            VARCHAR,
            notes               VARCHAR,
            tags                VARCHAR[],
            info                JSON,
            material            VARCHAR NOT NULL,
            penetrator          VARCHAR NOT NULL,
            energizing          VARCHAR NOT NULL,
            blade_thickness_mm  DOUBLE,
            blade_width_mm      DOUBLE,
            spring_count        INTEGER NOT NULL,
            sprung_mass_kg      DOUBLE NOT NULL,
            surface_offset_mm   DOUBLE NOT NULL,
            sampling_rate_hz    DOUBLE NOT NULL,
            n_samples           BIGINT NOT NULL,
            duration_s          DOUBLE NOT NULL,
            pen_version         VARCHAR NOT NULL,
            geometry            VARCHAR NOT NULL DEFAULT 'blade'
        );
        INSERT INTO runs SELECT *, 'blade' FROM keep_runs;
        CREATE TABLE run_parameters (
            run_id      VARCHAR NOT NULL REFERENCES runs(run_id),
            kind        VARCHAR NOT NULL,
            name        VARCHAR NOT NULL,
            parameters  JSON NOT NULL,
            PRIMARY KEY (run_id, kind)
        );
        INSERT INTO run_parameters SELECT * FROM keep_parameters;
        CREATE TABLE stages (
            run_id          VARCHAR NOT NULL REFERENCES runs(run_id),
            stage_no        INTEGER NOT NULL,
            stage           VARCHAR NOT NULL,
            parent_no       INTEGER,
            path            VARCHAR NOT NULL,
            content_sha256  VARCHAR NOT NULL,
            command         VARCHAR NOT NULL,
            parameters      JSON NOT NULL,
            pen_version     VARCHAR NOT NULL,
            created_at      TIMESTAMP NOT NULL,
            PRIMARY KEY (run_id, stage_no)
        );
        INSERT INTO stages SELECT * FROM keep_stages;
        DROP TABLE keep_stages;
        DROP TABLE keep_parameters;
        DROP TABLE keep_runs;
    """),
    (5, "field records: soundings, snow profiles, free-fall drops", """
        CREATE TABLE records (
            record_id       VARCHAR PRIMARY KEY,
            content_sha256  VARCHAR NOT NULL UNIQUE,
            kind            VARCHAR NOT NULL,
            geometry        VARCHAR,
            drive           VARCHAR NOT NULL,
            sensors         VARCHAR NOT NULL,
            name            VARCHAR NOT NULL,
            source          VARCHAR NOT NULL,
            source_sha256   VARCHAR NOT NULL,
            source_format   VARCHAR NOT NULL,
            n_rows          BIGINT NOT NULL,
            depth_max_m     DOUBLE,
            channels        VARCHAR[] NOT NULL,
            header          JSON NOT NULL,
            path            VARCHAR NOT NULL,
            ingested_at     TIMESTAMP NOT NULL,
            command         VARCHAR NOT NULL,
            pen_version     VARCHAR NOT NULL
        );
    """),
)

LATEST = MIGRATIONS[-1][0]
