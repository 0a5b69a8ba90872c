"""Motion: targeting, trajectories, the grab task, the control step, its scheduling and the safety clamps."""
