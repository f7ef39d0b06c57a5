"""The shading program's parts, one per module; :mod:`..program` is the program's top and
imports every name of theirs (see its docstring for the list)."""
