"""The resource model: what a scene's run costs in time, memory and disk.

Holds the resource estimate and its refusal (``resources``), the per-stage
cost estimators (``costs``, ``costs_measured``, ``costs_montecarlo``) and the process tree's
measured memory (``memory``).

May import: ``run.stages``, ``run.scene``, ``run.folder``, the modules at
``run/`` itself (``interrupts``, ``progress``, ``console``) and the layers
below ``run``.
"""
