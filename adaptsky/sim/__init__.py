"""The simulation: NOMA maths, actions, user layouts, observations and the batched environment
(numpy, vectorised over layouts)."""
