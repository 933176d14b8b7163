"""What users run: the ``kruskal`` command line, direct simulation, experiments, figures and reports."""
