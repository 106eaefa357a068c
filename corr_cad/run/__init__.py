"""Run: scenes, the stage pipeline, the output folder and the command line.

Subpackages by concept, lowest first: the scene schema and reader
(``scene``) and the output-folder contract (``folder``); the stage graph and
stage bodies (``stages``); the resource model (``budget``); the stage graph's
runner (``pipeline``); the benchmarks (``bench``); the CLI (``cli``). The
small shared modules (``interrupts``, ``progress``, ``console``,
``dask_exec``, ``cli_messages``) sit below them all.

May import: every layer below it. Nothing below imports this layer. Inside
it, a subpackage imports only those before it in this list
(``tests/test_layout.py`` holds the order).
"""
