"""The `report` job (:mod:`.job`), its options (:mod:`.options`) and the sections of a page
(:mod:`.sections`)."""
