"""Drake: the engine (:mod:`.engine`), its export as URDF and SDFormat files and a sidecar (:mod:`.export`) and
the replay of that export (:mod:`.replay`).

Nothing is imported here: pydrake is an optional library, loaded when the registry asks for one of these modules.
"""
