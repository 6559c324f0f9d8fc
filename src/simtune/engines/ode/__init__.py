"""ODE: the engine (:mod:`.engine`), its parameter mapping (:mod:`.mapping`, shared by the engine and its export)
and its export as one sidecar (:mod:`.export`); ODE has no model file format, so nothing replays an export.

Nothing is imported here: ODE is an optional library, loaded when the registry asks for one of these modules.
"""
