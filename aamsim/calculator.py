"""CALC: BlueSky's in-line calculator, for arithmetic only.

BlueSky evaluates the text as Python (``eval``) with its math, geo and aero
functions in scope, so ``CALC bs.traf.ntraf`` reads its internals. aamsim
evaluates numbers, ``+ - * / // % **`` (and ``^`` for power, as BlueSky's
second try), parentheses and the functions and constants of :mod:`math`
plus BlueSky's ``sind``, ``cosd``, ``tand``, ``deg(d, m, s)`` and
``rad(d, m, s)``; nothing else is evaluated, so a scenario or a remote client
cannot run code. CALC never changes the simulation.
"""

from __future__ import annotations

import ast
import math
import operator
from collections.abc import Callable
from typing import Any

_BINARY: dict[type, Callable[[Any, Any], Any]] = {
    ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv,
    ast.FloorDiv: operator.floordiv, ast.Mod: operator.mod, ast.Pow: operator.pow,
}
_UNARY: dict[type, Callable[[Any], Any]] = {ast.UAdd: operator.pos, ast.USub: operator.neg}
_NAMES: dict[str, Any] = {name: getattr(math, name) for name in dir(math) if not name.startswith("_")}
_NAMES.update({
    "sind": lambda x: math.sin(math.radians(x)),
    "cosd": lambda x: math.cos(math.radians(x)),
    "tand": lambda x: math.tan(math.radians(x)),
    "deg": lambda d, m, s: float(d) + float(m) / 60.0 + float(s) / 3600.0,
    "rad": lambda d, m, s: math.radians(float(d) + float(m) / 60.0 + float(s) / 3600.0),
    "v": math.sqrt,
})
MAX_POWER = 10_000  # 9**9**9 would take minutes: exponents are capped
MAX_LENGTH = 1000


class CalcError(ValueError):
    """The expression is not arithmetic aamsim evaluates."""


def calculate(text: str) -> float | int:
    """Value of an arithmetic expression (see the module's docstring)."""
    if len(text) > MAX_LENGTH:
        raise CalcError(f"expression longer than {MAX_LENGTH} characters")
    try:
        tree = ast.parse(text.strip().replace("^", "**"), mode="eval")
    except SyntaxError:
        raise CalcError(f'"{text}" is not an expression') from None
    return _eval(tree.body, text)


def _eval(node: ast.AST, text: str) -> Any:
    if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) and not isinstance(node.value, bool):
        return node.value
    if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
        left, right = _eval(node.left, text), _eval(node.right, text)
        if isinstance(node.op, ast.Pow) and abs(right) > MAX_POWER:
            raise CalcError(f"exponent {right} too large")
        try:
            return _BINARY[type(node.op)](left, right)
        except (ArithmeticError, ValueError) as exc:
            raise CalcError(str(exc)) from None
    if isinstance(node, ast.UnaryOp) and type(node.op) in _UNARY:
        return _UNARY[type(node.op)](_eval(node.operand, text))
    if isinstance(node, ast.Name) and node.id.lower() in _NAMES and not callable(_NAMES[node.id.lower()]):
        return _NAMES[node.id.lower()]
    if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id.lower() in _NAMES
            and callable(_NAMES[node.func.id.lower()]) and not node.keywords):
        args = [_eval(a, text) for a in node.args]
        try:
            return _NAMES[node.func.id.lower()](*args)
        except (ArithmeticError, ValueError, TypeError) as exc:
            raise CalcError(str(exc)) from None
    raise CalcError(f'"{ast.unparse(node)}" in "{text}": aamsim evaluates arithmetic and math functions only')
