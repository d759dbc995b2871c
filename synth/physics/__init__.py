"""The mechanics of one drop: materials, the scene, the plate's point impedance, the Hertz
contact (with its compiled kernels) and the bounce scheduler that strings impacts together.
See docs/physics.md."""
