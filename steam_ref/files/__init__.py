"""Files steam_ref writes for a user: written whole or not at all.

- :mod:`~steam_ref.files.replace`: :func:`replace_file`, a file written beside its target and moved over it in one
  step, so a full disk, an error or an interrupt mid-write leaves what was there as it was and no temporary behind.

A layer-0 leaf (it imports only :mod:`steam_ref.errors`, and no NumPy): the command's output checks
(``cli/paths.py``, loaded before the solvers) and the homework's handouts both write through it.
"""

from .replace import replace_file

__all__ = ["replace_file"]
