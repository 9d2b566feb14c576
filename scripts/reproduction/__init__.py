"""The reproduction of the paper behind ``scripts/reproduce.py`` (``make reproduce``).

* ``record``: the run's record (comparison rows, texts, timings, facts), the paper's numbers.
* ``solution``: parts 1 and 2, the multibody OCP solution and its FE replay.
* ``campaigns``: running a campaign (spawned worker or inline) and its step breakdown.
* ``loop``: parts 3 and 4, the active-learning loop and the remedies, as rows and figures.
* ``figures``: every figure (matplotlib, the ``reproduce`` extra).
* ``report``: the machine and the markdown page, with the verdict.
* ``cli``: the command line (``python scripts/reproduce.py --help``).

Imports of alcove, NumPy and matplotlib are inside the functions: ``--help`` and the
budget estimate need none of them.
"""
