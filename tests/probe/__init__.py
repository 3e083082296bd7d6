"""The probe of bad inputs and hostile cases of every subcommand (issue 45): ``cases`` holds the
table and the runner; ``test_bad_inputs`` runs each case under pytest, and
``bench/probe_bad_inputs.py`` prints the totals per class."""
