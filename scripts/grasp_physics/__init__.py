"""Physics grasp-success evaluation (MuJoCo): objects, gripper models from the gripper YAML,
and the simulated grasp trial. Used by scripts/evaluate_grasps_physics.py and its tests.
Runs in the venv scripts/setup_venv.sh creates (mujoco, trimesh, coacd)."""
