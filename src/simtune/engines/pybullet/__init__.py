"""PyBullet: the engine (:mod:`.engine`), its parameter mapping (:mod:`.mapping`, shared by the engine and its
export), its export as URDF files and a sidecar (:mod:`.export`) and the replay of that export (:mod:`.replay`).

Nothing is imported here: PyBullet is an optional library, loaded when the registry asks for one of these modules.
"""
