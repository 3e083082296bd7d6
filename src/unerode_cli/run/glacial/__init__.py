"""Runs of the coupled glacier model (001 §3–6) as the jobs take them: the options of a glacier
run declared once (``options``), the run's plan (``plan``), its time steps with checkpoints and
resume (``steps``) and its outputs (``outputs``). ``glaciate`` runs it from its options,
``climate-run --process glacial`` with the ELA and sea level of a chronology."""
