"""The simulation: its explicit state with a UAV axis and step (``state``), NOMA maths
(``noma``), the reward of eq. 13 as named terms (``reward``), actions, user layouts,
observations and the batched environment (``batch``), in numpy, vectorised over layouts."""
