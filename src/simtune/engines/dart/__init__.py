"""DART: the engine (:mod:`.engine`), its export as URDF files and a sidecar (:mod:`.export`) and the replay of
that export (:mod:`.replay`).

Nothing is imported here: dartpy is an optional library, loaded when the registry asks for one of these modules.
"""
