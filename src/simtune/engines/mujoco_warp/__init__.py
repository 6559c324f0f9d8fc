"""MuJoCo Warp: a whole population as one batch of MuJoCo worlds (:mod:`.engine`); it exports and replays as MuJoCo.

Nothing is imported here: Warp is an optional library, loaded when the registry asks for the engine.
"""
