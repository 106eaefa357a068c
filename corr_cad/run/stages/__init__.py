"""The stages: the stage graph, the run context and the stage bodies.

Holds the stage graph (``stages``), the context a run hands from stage to
stage (``context``), the stage that runs in a pool worker (``concurrent``)
and the stage bodies (``stages_*``).

May import: ``run.scene``, ``run.folder``, the modules at ``run/`` itself
(``interrupts``, ``progress``, ``console``) and the layers below ``run``.
"""
