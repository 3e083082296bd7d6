"""The `report` job (:mod:`.job`), its options (:mod:`.options`) and the sections of a page
(:mod:`.sections`; an ensemble's in :mod:`.ensemble`, its values as the reader wants them in
:mod:`.spec_values`, maps on the CRS's axes in :mod:`.maps`)."""
