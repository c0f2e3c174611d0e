"""What the learners share, in one place: network shapes and the actor's head shape
(``shapes``), the checkpoint's Adam and weights checks and the replay's fields and sizing
(``checkpoint``), both torch-free; the stacked parameters with the one Adam (``stacked``) and
the action distributions over a head (``heads``), torch."""
