"""``simtune check``: a task's recordings against its schedule, with proposed targets for rests the robot did not
reach as described (task), and a project folder's robot, recordings and engines (project)."""
