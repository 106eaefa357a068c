"""The benchmarks of ``corr-cad bench``: one module per study.

Holds the study runner (``bench``), the shared helpers (``bench_common``)
and the studies (``bench_*``).

May import: ``run.pipeline``, ``run.budget``, ``run.stages``, ``run.scene``,
``run.folder``, the modules at ``run/`` itself and the layers below ``run``.
"""
