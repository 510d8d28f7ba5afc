"""The scripts of ``make figures``: one per figure of the paper (``python -m figures.figNN_<name>``) and ``make_all.py``."""
