"""Run: scenes, the stage pipeline, the output folder and the command line.

Holds the scene schema and reader (``scene``, ``scene_schema``,
``scene_text``, ``schema_json``), the resource estimate (``resources``), the
stage graph (``pipeline``) and the stage bodies (``stages_*``), the stage that
runs in a pool worker (``concurrent``), the output-folder contract
(``outputs``), console text and progress lines, the benchmarks (``bench``)
and the CLI (``cli``).

May import: every layer below it. Nothing below imports this layer.
"""
