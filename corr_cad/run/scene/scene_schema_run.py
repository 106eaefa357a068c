"""Scene sections on how a run may use the machine: ``[budget]`` (memory,
output size, the long-run warning) and ``[dask]`` (time-outs of the Dask
executor); part of :data:`corr_cad.run.scene.scene_schema.SCHEMA`."""

from __future__ import annotations

from corr_cad.run.scene.scene_key import Key

SECTIONS: dict[str, dict[str, Key]] = {
    "budget": {
        "memory_gb": Key(
            "float",
            None,
            "largest memory the run may plan to use, GB: this process and its pool workers "
            "(default 3; --max-memory overrides)",
            low=0,
            high=1024.0,
            example=3.0,
            note="and at most this machine's memory",
        ),
        "output_gb": Key(
            "float",
            None,
            "largest total size of the files the run may write, GB (default 1; "
            "--max-output overrides)",
            low=0,
            high=100_000.0,
            example=1.0,
        ),
        "time_warning_s": Key(
            "float",
            None,
            "warn (and still run) when the run is estimated to take longer, s (default 60; "
            "--warn-time overrides)",
            low=0,
            high=1e7,
            example=60.0,
        ),
    },
    "dask": {
        "connect_timeout_s": Key(
            "float",
            None,
            "--executor dask: give up when the scheduler has not answered within this, s "
            "(default 5; --dask-connect-timeout overrides)",
            low=0,
            high=600.0,
            example=5.0,
        ),
        "no_workers_timeout_s": Key(
            "float",
            None,
            "--executor dask: give up when the scheduler has had no worker for this long, s "
            "(default 30; --dask-no-workers-timeout overrides)",
            low=0,
            high=86400.0,
            example=30.0,
        ),
        "stall_timeout_s": Key(
            "float",
            None,
            "--executor dask: give up when no task has finished for this long, s (default "
            "120, and at least 3 times the estimated time of one task; "
            "--dask-stall-timeout overrides)",
            low=0,
            high=86400.0,
            example=120.0,
        ),
    },
}
