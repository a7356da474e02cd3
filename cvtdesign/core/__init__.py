"""The physics: the resolved layout, geometry and kinematics, contact mechanics, effects, the compiled model, layout checks and the figures of merit."""
