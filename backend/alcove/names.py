"""The name a user gives an object (task, oracle, campaign, surrogate configuration, token).

Leading and trailing whitespace is dropped before the length is checked, so a name made only
of spaces is refused (it would list as an empty, unclickable row) and " a " is stored as "a".
"""

from __future__ import annotations

from typing import Annotated

from pydantic import StringConstraints

Name = Annotated[str, StringConstraints(strip_whitespace=True, min_length=1, max_length=200)]
