"""svbrdf.trainer: torch side of the toolkit (models, losses, the two-stage GAN training, benchmark)."""
