"""Label-free quality scores: the highlight burn-in of a set of maps (:mod:`.burn_in`) and the rule that skips a
refine when the preview already explains the photo (:mod:`.preview_check`)."""
