"""The dynamic model (docs/dynamics.md): the layout's inertias and steering motor, the ODE compiled from the steady
model's equations, its integration and its linearisation."""
