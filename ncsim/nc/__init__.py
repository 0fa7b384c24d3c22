"""NC front end: program text -> Program (parse) -> Path (interpret).

``parse`` (the Lark grammar) and ``fastparse`` (compiled scanner for plain blocks) build the
``program`` nodes; ``expr`` evaluates expressions, ``modal`` holds the G groups and the modal
state, ``frames`` the 840D frame chain; ``interpret`` executes the blocks in the 840D order with its
collaborators ``context``, ``flow``, ``variables``, ``sysvars``, ``calls``, ``words``,
``settings``, ``moves``, ``columns`` and ``fastops`` (its docstring says which does what, and
where a new word, statement or cycle goes).
Imports nothing of ``plan``, ``report``, ``gap`` or ``cli`` (``tests/test_layering.py``).
"""
