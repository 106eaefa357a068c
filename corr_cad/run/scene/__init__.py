"""The scene: the TOML schema, the reader and its checks.

Holds the schema and its key tables (``scene_schema*``, ``scene_key``), the
reader (``scene``) with its sections (``scene_drive``, ``scene_first_stage``,
``scene_modification``, ``scene_montecarlo``), the text of its messages and
hints (``scene_text``, ``scene_hints``), the structural limits a scene must
keep (``limits``) and the JSON Schema of the scene (``schema_json``).

May import: the layers below ``run`` and the modules at ``run/`` itself
(``interrupts``, ``progress``, ``console``). Nothing else in ``run`` is imported
from here.
"""
