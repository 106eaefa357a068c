"""The output folder: its contract, its lock and its manifest.

Holds the staging and swap of a run's output folder (``outputs``), the lock
file (``lockfile``), the manifest file (``manifest_file``) and the names a run
may write (``names``).

May import: the layers below ``run`` and the modules at ``run/`` itself
(``interrupts``, ``progress``, ``console``). Independent of ``run.scene``.
"""
