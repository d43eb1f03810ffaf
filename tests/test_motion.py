"""Driver motions (linkdyn.motion): values, exact derivatives, batching, validation."""

import dataclasses
import math

import numpy as np
import pytest

from linkdyn.errors import ModelError
from linkdyn.expr import ExpressionError
from linkdyn.motion import ConstantSpeed, ExpressionMotion, TableMotion

T2 = np.linspace(0.0, 1.3, 24).reshape(4, 6)          # a 2-D batch of times, s


def central(motion, t, h=1e-6):
    """Central differences of q and qd (error O(h^2), about 1e-10 relative here)."""
    q0 = motion.evaluate(t - h)
    q1 = motion.evaluate(t + h)
    return (q1[0] - q0[0]) / (2 * h), (q1[1] - q0[1]) / (2 * h)


# -------------------------------------------------------------------------- ConstantSpeed

def test_constant_speed():
    m = ConstantSpeed(4.71238898, start=0.3)
    q, qd, qdd = m.evaluate(T2)
    assert q.shape == qd.shape == qdd.shape == T2.shape
    assert q.dtype == qd.dtype == qdd.dtype == np.float64
    np.testing.assert_allclose(q, 0.3 + 4.71238898 * T2, rtol=1e-15)
    assert np.all(qd == 4.71238898) and np.all(qdd == 0)
    assert m.period == pytest.approx(2 * math.pi / 4.71238898, rel=1e-15)
    assert ConstantSpeed(-2.0).period == pytest.approx(math.pi)
    assert ConstantSpeed(0.0).period is None
    assert ConstantSpeed(4.71238898).describe() == "constant speed 4.712 rad/s from 0"
    assert ConstantSpeed(0.02).describe("m") == "constant speed 0.02 m/s from 0"


def test_constant_speed_is_frozen_and_validated():
    m = ConstantSpeed(1.0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        m.speed = 2.0
    with pytest.raises(ValueError, match="speed"):
        ConstantSpeed(float("nan"))
    assert ConstantSpeed(3).speed == 3.0 and isinstance(ConstantSpeed(3).speed, float)


# ----------------------------------------------------------------------- ExpressionMotion

def test_expression_motion_matches_closed_form():
    m = ExpressionMotion("0.3 + 6.0*t + 0.4*sin(5*t)")
    q, qd, qdd = m.evaluate(T2)
    assert q.shape == qd.shape == qdd.shape == T2.shape
    np.testing.assert_allclose(q, 0.3 + 6 * T2 + 0.4 * np.sin(5 * T2), rtol=1e-15)
    np.testing.assert_allclose(qd, 6 + 2 * np.cos(5 * T2), rtol=1e-14)
    np.testing.assert_allclose(qdd, -10 * np.sin(5 * T2), rtol=1e-14, atol=1e-14)


@pytest.mark.parametrize("text", ["0.3 + 6.0*t + 0.4*sin(5*t)", "exp(-t)*cos(3*t)",
                                  "sqrt(1 + t**2)", "(1 + t)/(2 + t)", "2**t"])
def test_expression_motion_derivatives_match_finite_differences(text):
    m = ExpressionMotion(text)
    t = np.linspace(0.1, 1.2, 12).reshape(3, 4)
    _, qd, qdd = m.evaluate(t)
    fd_q, fd_qd = central(m, t)
    np.testing.assert_allclose(qd, fd_q, rtol=1e-7, atol=1e-8 * np.abs(qd).max())
    np.testing.assert_allclose(qdd, fd_qd, rtol=1e-7, atol=1e-8 * np.abs(qdd).max())


def test_expression_motion_scale_converts_units():
    deg = ExpressionMotion("30*t + 10*sin(t)", scale=math.pi / 180)
    q, qd, qdd = deg.evaluate(T2)
    np.testing.assert_allclose(q, np.radians(30 * T2 + 10 * np.sin(T2)), rtol=1e-14)
    np.testing.assert_allclose(qd, np.radians(30 + 10 * np.cos(T2)), rtol=1e-14)
    np.testing.assert_allclose(qdd, np.radians(-10 * np.sin(T2)), atol=1e-15)
    assert deg.describe() == "q(t) = 0.0174533*(30*t + 10*sin(t)) rad"
    assert ExpressionMotion("0.3 + 6.0*t").describe() == "q(t) = 0.3 + 6.0*t rad"


def test_constant_expression_keeps_batch_shape():
    q, qd, qdd = ExpressionMotion("0.25").evaluate(T2)
    assert q.shape == qd.shape == qdd.shape == T2.shape
    assert np.all(q == 0.25) and np.all(qd == 0) and np.all(qdd == 0)


def test_expression_motion_rejects_bad_text_at_construction():
    with pytest.raises(ExpressionError, match=r"unknown name 'tt'.*did you mean 't'\?"):
        ExpressionMotion("sin(tt)")
    with pytest.raises(ExpressionError, match=r"'\*\*'"):
        ExpressionMotion("t^2")


def test_expression_motion_is_frozen():
    m = ExpressionMotion("t")
    with pytest.raises(dataclasses.FrozenInstanceError):
        m.text = "2*t"
    assert m == ExpressionMotion("t")


# ---------------------------------------------------------------------------- TableMotion

def sine_table(n=101):
    t = np.linspace(0.0, 2 * np.pi, n)
    return TableMotion(t, np.sin(t))


def test_table_reproduces_a_smooth_function():
    # Cubic spline, knot spacing h = 2 pi / 100 = 0.063: errors about h^4/384 max|q4| ~ 4e-8
    # in q, h^3/24 ~ 3e-6 in qd, h^2/12 ~ 3.3e-4 in qdd.
    t = np.linspace(0.0, 2 * np.pi, 2001)
    q, qd, qdd = sine_table().evaluate(t)
    np.testing.assert_allclose(q, np.sin(t), atol=1e-7)
    np.testing.assert_allclose(qd, np.cos(t), atol=5e-6)
    np.testing.assert_allclose(qdd, -np.sin(t), atol=5e-4)
    q, qd, qdd = sine_table(401).evaluate(t)            # h / 4: errors shrink as h^4, h^3, h^2
    np.testing.assert_allclose(q, np.sin(t), atol=1e-7 / 4**4)
    np.testing.assert_allclose(qd, np.cos(t), atol=5e-6 / 4**3)
    np.testing.assert_allclose(qdd, -np.sin(t), atol=5e-4 / 4**2)


def test_table_passes_through_its_rows():
    m = sine_table(37)
    q, _, _ = m.evaluate(m.t)
    np.testing.assert_allclose(q, m.q, atol=1e-15)


def test_table_derivatives_are_exact_derivatives_of_the_spline():
    m = sine_table(13)                                   # coarse: spline differs from sin
    t = np.linspace(0.01, 2 * np.pi - 0.01, 300).reshape(20, 15)
    _, qd, qdd = m.evaluate(t)
    fd_q, fd_qd = central(m, t)
    np.testing.assert_allclose(qd, fd_q, atol=1e-8)
    np.testing.assert_allclose(qdd, fd_qd, atol=1e-7)
    assert np.abs(qdd + np.sin(t)).max() > 1e-3         # so this is not a test of sin itself


def test_table_is_cubic_exact_and_scaled():
    t = np.array([0.0, 0.3, 0.5, 1.1, 1.6, 2.0])
    m = TableMotion(t, t**3 - 2 * t, scale=1e-3)         # mm -> m; not-a-knot reproduces cubics
    ts = np.linspace(0, 2, 9).reshape(3, 3)
    q, qd, qdd = m.evaluate(ts)
    assert q.shape == qd.shape == qdd.shape == (3, 3)
    np.testing.assert_allclose(q, 1e-3 * (ts**3 - 2 * ts), atol=1e-15)
    np.testing.assert_allclose(qd, 1e-3 * (3 * ts**2 - 2), atol=1e-14)
    np.testing.assert_allclose(qdd, 1e-3 * 6 * ts, atol=1e-13)
    assert m.describe("m") == "table of 6 rows, t from 0 to 2 s, q x 0.001 to m"


def test_table_outside_its_range_names_the_table_its_range_and_the_run():
    m = sine_table()                                     # t from 0 to 2 pi
    q, qd, qdd = m.evaluate(np.array([[-1e-12, 0.0], [2 * np.pi * (1 + 1e-12), np.pi]]))
    for a in (q, qd, qdd):                               # rounding at the ends is tolerated
        assert np.all(np.isfinite(a))
    np.testing.assert_allclose(q[0], np.sin(0.0), atol=1e-12)
    for t, run in (([0.0, 7.0], "t = 0 to 7 s"), ([-0.5, 1.0], "t = -0.5 to 1 s")):
        with pytest.raises(ModelError) as info:
            m.evaluate(np.array(t))
        assert "covers t = 0 to 6.28319 s" in str(info.value) and run in str(info.value)
    located = TableMotion(m.t, m.q, origin="lift.csv", model="m.toml", model_field="drivers[0].motion.file")
    with pytest.raises(ModelError) as info:
        located.evaluate(np.linspace(0.0, 10.0, 5))
    e = info.value
    assert e.file == "m.toml" and e.field == "drivers[0].motion.file" and "'lift.csv'" in e.message


def test_table_is_frozen_and_owns_its_data():
    t, q = np.linspace(0, 1, 5), np.linspace(0, 1, 5) ** 2
    m = TableMotion(t, q)
    q[:] = 0                                             # caller's array changes later
    assert m.q[-1] == 1.0
    with pytest.raises(ValueError):
        m.q[0] = 5.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        m.scale = 2.0


@pytest.mark.parametrize("t, q, message", [
    ([0, 1, 2], [0, 1, 2], "at least 4 rows"),
    ([0, 1, 2, 3], [0, 1, 2], "equal length"),
    ([[0, 1], [2, 3]], [[0, 1], [2, 3]], "equal length"),
    ([0, 1, 1, 3], [0, 1, 2, 3], r"row 3 has t = 1 after t = 1"),
    ([0, 2, 1, 3], [0, 1, 2, 3], "strictly increase"),
    ([0, 1, 2, 3], [0, np.nan, 2, 3], "row 2 .* not finite"),
    ([0, 1, np.inf, 3], [0, 1, 2, 3], "row 3 .* not finite"),
])
def test_table_validation(t, q, message):
    with pytest.raises(ValueError, match=message):
        TableMotion(np.array(t, float), np.array(q, float))


# --------------------------------------------------------------------------------- CSV files

def test_from_csv_with_and_without_header(tmp_path):
    t = np.linspace(0, 1, 6)
    body = "".join(f"{a!r},{b!r}\n" for a, b in zip(t.tolist(), (t**2).tolist()))
    with_header = tmp_path / "a.csv"
    with_header.write_text("t,q\n" + body)
    bare = tmp_path / "b.csv"
    bare.write_text("# profile\n\n" + body.replace(",", ", ") + "\n")
    for path in (with_header, bare):
        m = TableMotion.from_csv(path, scale=2.0)
        np.testing.assert_array_equal(m.t, t)
        np.testing.assert_array_equal(m.q, t**2)
        np.testing.assert_allclose(m.evaluate(0.5)[0], 2 * 0.25, rtol=1e-14)


def test_from_csv_missing_file(tmp_path):
    path = tmp_path / "nowhere" / "profile.csv"
    with pytest.raises(FileNotFoundError, match="profile.csv"):
        TableMotion.from_csv(path)


@pytest.mark.parametrize("text, message", [
    ("t,q\n0,0\n1,1\n2,x\n3,3\n", r"line 4: expected two numbers 't,q', got '2,x'"),
    ("0,0\n1,1\n2,2,2\n3,3\n", "line 3: expected two numbers"),
    ("0,0\nt,q\n2,2\n3,3\n", "line 2: expected two numbers"),     # header only on top
    ("t,q\n0,0\n1,1\n1,2\n3,3\n", "line 4: t = 1 does not increase"),
    ("t,q\n0,0\n1,nan\n2,2\n3,3\n", "line 3: t and q must be finite"),
    ("t,q\n0,0\n1,1\n2,2\n", "at least 4 rows.*got 3"),
    ("t,q\n", "at least 4 rows.*got 0"),
])
def test_from_csv_bad_content_names_the_file_and_line(tmp_path, text, message):
    path = tmp_path / "profile.csv"
    path.write_text(text)
    with pytest.raises(ValueError, match=message) as info:
        TableMotion.from_csv(path)
    assert str(path) in str(info.value)


def test_invalid_values_are_model_errors_and_value_errors(tmp_path):
    from linkdyn.errors import LinkdynError
    for make in (lambda: ConstantSpeed(math.inf), lambda: ExpressionMotion("sinn(t)"),
                 lambda: TableMotion(np.arange(3.0), np.arange(3.0))):
        with pytest.raises(ModelError) as info:
            make()
        assert isinstance(info.value, ValueError) and isinstance(info.value, LinkdynError)
    (tmp_path / "p.csv").write_text("t,q\n0,0\n1,1\n" + "9" * 100_000 + ",x\n")
    with pytest.raises(ModelError) as info:
        TableMotion.from_csv(tmp_path / "p.csv")
    assert info.value.field == "line 4" and "(100,002 characters)" in str(info.value)
    assert len(str(info.value)) < 300
