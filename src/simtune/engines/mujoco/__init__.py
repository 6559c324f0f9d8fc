"""MuJoCo: the engine (:mod:`.engine`), its export as MJCF (:mod:`.export`) and the replay of that
export (:mod:`.replay`).

Nothing is imported here: MuJoCo is an optional library, loaded when the registry asks for one of these modules.
"""
