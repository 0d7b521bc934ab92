"""Simulation for demos and tests without hardware: gimbals with a state model,
a controller that behaves like real ones, and a virtual wire with taps."""
