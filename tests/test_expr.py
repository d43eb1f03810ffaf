"""Safe expression parsing and exact symbolic derivatives (linkdyn.expr)."""

import ast
import math
import re
from pathlib import Path

import numpy as np
import pytest

import linkdyn.expr as expr_module
from linkdyn.expr import Expr, ExpressionError, parse

T = np.linspace(0.05, 1.9, 41)   # inside every test function's domain

# text, f, f', f'' (derived by hand)
CASES = [
    ("0.3 + 6.0*t + 0.4*sin(5*t)",
     lambda t: 0.3 + 6 * t + 0.4 * np.sin(5 * t),
     lambda t: 6 + 2 * np.cos(5 * t),
     lambda t: -10 * np.sin(5 * t)),
    ("t**2", lambda t: t**2, lambda t: 2 * t, lambda t: 2 + 0 * t),
    ("exp(-t)*cos(3*t)",
     lambda t: np.exp(-t) * np.cos(3 * t),
     lambda t: -np.exp(-t) * (np.cos(3 * t) + 3 * np.sin(3 * t)),
     lambda t: np.exp(-t) * (6 * np.sin(3 * t) - 8 * np.cos(3 * t))),
    ("2**t", lambda t: 2**t, lambda t: np.log(2) * 2**t, lambda t: np.log(2) ** 2 * 2**t),
    ("sqrt(1+t**2)",
     lambda t: np.sqrt(1 + t**2),
     lambda t: t / np.sqrt(1 + t**2),
     lambda t: (1 + t**2) ** -1.5),
    ("t*sin(t)",                                                   # product
     lambda t: t * np.sin(t),
     lambda t: np.sin(t) + t * np.cos(t),
     lambda t: 2 * np.cos(t) - t * np.sin(t)),
    ("(1+t)/(2-t)",                                                # quotient
     lambda t: (1 + t) / (2 - t),
     lambda t: 3 / (2 - t) ** 2,
     lambda t: 6 / (2 - t) ** 3),
    ("t**t",                                                       # general f**g
     lambda t: t**t,
     lambda t: t**t * (np.log(t) + 1),
     lambda t: t**t * ((np.log(t) + 1) ** 2 + 1 / t)),
    ("log(1 + t**2)",
     lambda t: np.log(1 + t**2),
     lambda t: 2 * t / (1 + t**2),
     lambda t: 2 * (1 - t**2) / (1 + t**2) ** 2),
    ("atan(t)", np.arctan, lambda t: 1 / (1 + t**2), lambda t: -2 * t / (1 + t**2) ** 2),
    ("tan(t/2)",
     lambda t: np.tan(t / 2),
     lambda t: 0.5 / np.cos(t / 2) ** 2,
     lambda t: 0.5 * np.tan(t / 2) / np.cos(t / 2) ** 2),
    ("asin(t/2) + acos(t/3)",
     lambda t: np.arcsin(t / 2) + np.arccos(t / 3),
     lambda t: 1 / np.sqrt(4 - t**2) - 1 / np.sqrt(9 - t**2),
     lambda t: t / (4 - t**2) ** 1.5 - t / (9 - t**2) ** 1.5),
    ("sinh(t)*cosh(t) - tanh(t)",
     lambda t: np.sinh(t) * np.cosh(t) - np.tanh(t),
     lambda t: np.cosh(2 * t) - 1 / np.cosh(t) ** 2,
     lambda t: 2 * np.sinh(2 * t) + 2 * np.tanh(t) / np.cosh(t) ** 2),
    ("sin(2*pi*t)**3 / e",
     lambda t: np.sin(2 * np.pi * t) ** 3 / np.e,
     lambda t: 6 * np.pi * np.sin(2 * np.pi * t) ** 2 * np.cos(2 * np.pi * t) / np.e,
     lambda t: 12 * np.pi**2 * np.sin(2 * np.pi * t)
     * (2 * np.cos(2 * np.pi * t) ** 2 - np.sin(2 * np.pi * t) ** 2) / np.e),
    ("-t**-0.5", lambda t: -t**-0.5, lambda t: 0.5 * t**-1.5, lambda t: -0.75 * t**-2.5),
]
IDS = [c[0] for c in CASES]


def complex_step(f: Expr, t: np.ndarray, h: float = 1e-30) -> np.ndarray:
    """df/dt = Im f(t + ih) / h: no subtractive cancellation, exact to rounding."""
    return f(t + 1j * h).imag / h


def richardson(g, t: np.ndarray, h: float = 1e-3) -> np.ndarray:
    """Central difference extrapolated twice (error O(h^6))."""
    def d(h):
        return (g(t + h) - g(t - h)) / (2 * h)

    r = [d(h), d(h / 2), d(h / 4)]
    r = [(4 * r[1] - r[0]) / 3, (4 * r[2] - r[1]) / 3]
    return (16 * r[1] - r[0]) / 15


@pytest.mark.parametrize("text, f, df, d2f", CASES, ids=IDS)
def test_values_and_derivatives_match_closed_forms(text, f, df, d2f):
    e = parse(text)
    np.testing.assert_allclose(e(T), f(T), rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(e.diff()(T), df(T), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(e.diff().diff()(T), d2f(T), rtol=1e-11, atol=1e-11)


@pytest.mark.parametrize("text", IDS)
def test_derivatives_match_complex_step(text):
    e = parse(text)
    d1, d2 = e.diff(), e.diff().diff()
    np.testing.assert_allclose(d1(T), complex_step(e, T), rtol=1e-13, atol=1e-13)
    np.testing.assert_allclose(d2(T), complex_step(d1, T), rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("text", IDS)
def test_derivatives_match_richardson_differences(text):
    e = parse(text)
    d1, d2 = e.diff(), e.diff().diff()
    scale1, scale2 = np.abs(d1(T)).max(), np.abs(d2(T)).max()
    np.testing.assert_allclose(d1(T), richardson(e, T), rtol=1e-8, atol=1e-9 * scale1)
    np.testing.assert_allclose(d2(T), richardson(d1, T), rtol=1e-8, atol=1e-9 * scale2)


def test_simplification_keeps_derivatives_small():
    q = parse("0.3 + 6.0*t + 0.4*sin(5*t)")
    assert str(q.diff()) == "6 + 2*cos(5*t)"
    assert str(q.diff().diff()) == "-10*sin(5*t)"
    assert str(parse("t**2").diff()) == "2*t"
    assert str(parse("t**2").diff().diff()) == "2"
    assert str(parse("3*t - 1").diff()) == "3"
    assert str(parse("sqrt(1+t**2)").diff()) == "t/sqrt(1 + t**2)"
    assert str(parse("pi*e").diff()) == "0"
    assert str(parse("sin(t)").diff().diff().diff().diff()) == "sin(t)"


@pytest.mark.parametrize("text", IDS + ["-(t - 1)**2", "2**(-t)", "(-t)**2", "t - (t - 1)",
                                        "t/(t/2)", "2*(3*(4*t))", "-3**2", "--t", "1e-05*t"])
def test_str_round_trips(text):
    e = parse(text)
    for g in (e, e.diff(), e.diff().diff()):
        np.testing.assert_allclose(parse(str(g))(T), g(T), rtol=1e-14)


def test_evaluate_broadcasts_and_keeps_batch_shape():
    t = np.linspace(0, 1, 12).reshape(3, 4)
    e = parse("0.3 + 6.0*t + 0.4*sin(5*t)")
    assert e(t).shape == (3, 4) and e(t).dtype == np.float64
    np.testing.assert_array_equal(e(t), e(t.ravel()).reshape(3, 4))
    c = parse("2*pi")                                   # constants take the shape of t too
    assert c(t).shape == (3, 4) and np.all(c(t) == 2 * np.pi)
    assert e.diff().diff().diff().diff()(t).shape == (3, 4)
    assert np.ndim(e(0.5)) == 0


def test_several_variables():
    e = parse("x*sin(y) + y**2", variables=("x", "y"))
    assert e.variables == {"x", "y"}
    assert str(e.diff("x")) == "sin(y)"
    x, y = np.array([[1.0], [2.0]]), np.array([0.1, 0.2, 0.3])
    assert e.evaluate(x=x, y=y).shape == (2, 3)
    np.testing.assert_allclose(e.diff("y").evaluate(x=x, y=y), x * np.cos(y) + 2 * y, rtol=1e-15)
    with pytest.raises(ValueError, match="y"):
        e.evaluate(x=1.0)
    with pytest.raises(ValueError, match="invalid variable name"):
        parse("sin(t)", variables=("sin",))


def test_expressions_are_immutable_and_comparable():
    e = parse("sin(t)")
    with pytest.raises(AttributeError):
        e.op = "cos"
    assert parse("sin(t)") == e and hash(parse("sin(t)")) == hash(e)
    assert parse("arctan(t)") == parse("atan(t)")           # NumPy spellings accepted


def test_outside_domain_is_nan_not_an_exception():
    with np.errstate(invalid="ignore"):
        assert np.isnan(parse("log(t)")(-1.0))
        assert np.isnan(parse("sqrt(t)").diff()(-1.0))


# (text, fragments the one-line message must contain)
BAD = [
    ("sin(tt)", ["unknown name 'tt'", "did you mean 't'?", "Allowed:"]),
    ("sinn(t)", ["unknown function 'sinn'", "did you mean 'sin'?"]),
    ("PI*t", ["'PI'", "did you mean 'pi'?"]),
    ("ln(t)", ["'ln'", "did you mean 'log'?"]),
    ("abs(t)", ["'abs'", "not smooth"]),
    ("t^2", ["'^'", "'**'"]),
    ("np.sin(t)", ["'np.sin'", "did you mean 'sin'?"]),
    ("math.pi", ["attribute access 'math.pi'"]),
    ("t[0]", ["'t[0]'", "subscript"]),
    ("sin(x=t)", ["keyword argument 'x='"]),
    ("sin(t, 1)", ["exactly one argument"]),
    ("lambda: t", ["lambda"]),
    ("t > 1", ["comparison"]),
    ("'abc'", ["unsupported constant", "'abc'"]),
    ("1j*t", ["'1j'"]),
    ("True", ["'True'"]),
    ("sin(t", ["invalid syntax", "never closed"]),
    ("", ["empty expression"]),
    ("__import__('os').system('echo hi')", ["call of", "__import__"]),
    ("__import__('os')", ["unknown function '__import__'"]),
    ("t % 2", ["'%'"]),
    ("t // 2", ["'//'"]),
    ("~t", ["'~'"]),
    ("sin", ["'sin'", "sin(t)"]),
    ("2(t + 1)", ["'2' is not a function", "'*'"]),
    ("1e999*t", ["too large"]),
    ("t if t else 1", ["conditional expression"]),
    ("-" * 300 + "t", ["nest"]),
    ("[t for t in ()]", ["unsupported syntax"]),
]


@pytest.mark.parametrize("text, fragments", BAD, ids=[b[0][:20] for b in BAD])
def test_bad_expressions_give_one_line_messages(text, fragments):
    with pytest.raises(ExpressionError) as info:
        parse(text)
    message = str(info.value)
    assert "\n" not in message and len(message) < 400
    for fragment in fragments:
        assert fragment in message


def test_expression_error_is_a_value_error():
    assert issubclass(ExpressionError, ValueError)
    with pytest.raises(ExpressionError, match="got int"):
        parse(5)


def test_source_never_evaluates_text():
    for module in ("expr.py", "motion.py"):
        source = (Path(expr_module.__file__).parent / module).read_text()
        assert not re.search(r"(?<![\w.])(eval|exec|compile)\s*\(", source)
        called = {getattr(n.func, "id", getattr(n.func, "attr", None))
                  for n in ast.walk(ast.parse(source)) if isinstance(n, ast.Call)}
        assert not called & {"eval", "exec", "compile", "__import__", "literal_eval"}


def test_numbers_and_constants():
    assert float(parse("pi")(0.0)) == math.pi and float(parse("e")(0.0)) == math.e
    assert float(parse("1.5e3 + -2")(0.0)) == 1498.0
    assert float(parse("  2*t  ")(3.0)) == 6.0
