"""Tasks of the qrg2019 recordings (same arm, lab and protocol as the seed paper)."""

from simtune.tasks.spec import ObjectSpec, Phase, TaskSpec

SINGLE = TaskSpec(
    name="single",
    description="one joint move: joint_2 to -100 deg (kinematic, no contact)",
    duration=6.0,
    phases=(Phase(0.0, (0, -100, 0, 0, 0, 0)),),
    kp=10.0,
    has_public_recordings=True,
)

DOUBLE = TaskSpec(
    name="double",
    description="two joints (2 and 5) out and back twice (kinematic, no contact)",
    duration=20.0,
    phases=(
        Phase(0.0, (0, -90, 0, 0, -90, 0)),
        Phase(5.0, (0, 0, 0, 0, 0, 0)),
        Phase(10.0, (0, -90, 0, 0, 90, 0)),
        Phase(15.0, (0, 0, 0, 0, 0, 0)),
    ),
    kp=10.0,
)

CUBE = TaskSpec(
    name="cube",
    description="push a 75 mm plastic cube about 9 cm along +x",
    duration=20.0,
    phases=(
        Phase(0.0, (0, 30, 120, 90, 0, 0)),
        Phase(8.0, (0, -60, 65, 90, 0, 0)),
        Phase(14.0, (0, -67, 30, 90, 0, 0)),
    ),
    kp=10.0,
    object=ObjectSpec("cube", "plastic", 0.0884, (0.075, 0.075, 0.075), (0.5, 0.0), mocap_body="PCube"),
    has_public_recordings=True,
)

TASKS = (SINGLE, DOUBLE, CUBE)
