"""NC front end: program text -> Program (parse) -> Path (interpret)."""
