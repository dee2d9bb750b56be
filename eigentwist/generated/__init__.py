"""Generated evaluators (checked in; regenerate with ``eigentwist generate``).

A robot's generated files are named here, once: the code generator writes them under these
names (:mod:`eigentwist.codegen.generate`) and the runtime reads them by the same
(:mod:`eigentwist.runtime.loader`, :mod:`eigentwist.runtime.c_kernels`,
:mod:`eigentwist.runtime.userfile`). Importing this package imports nothing else.
"""

__all__ = ["FILES", "generated_name"]

#: target -> file name (``{robot}``: the robot's name): the NumPy evaluator (a module), the
#: C library's source and its header (one library, two files)
FILES = {"numpy": "{robot}_numpy.py", "c": "{robot}_c.c", "c_header": "{robot}_c.h"}


def generated_name(robot: str, target: str) -> str:
    """The file name of ``robot``'s generated ``target`` (a key of :data:`FILES`)."""
    return FILES[target].format(robot=robot)
