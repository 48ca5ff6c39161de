"""A notebook session: a two-dof model with a cubic spring and a one-sided stop, built in Python,
traced with Hill stability and automatic switching at a period doubling, exported and plotted,
with the user's matplotlib backend and settings left as they were."""

import matplotlib
import numpy as np
import pytest
import scipy.io
from scipy.integrate import solve_ivp

import contin

P = {"c": 0.05, "k": 1.0, "g": 0.3, "F": 0.15, "d": 0.3, "kc": 10.0}


def _equations_of_motion(w):
    """The same system written out by hand in numpy, for scipy's integrator (the independent reference)."""
    def rhs(t, y):
        x1, x2, v1, v2 = y
        contact = P["kc"] * max(x2 - P["d"], 0.0)
        a1 = P["F"] * np.cos(w * t) - P["c"] * (2 * v1 - v2) - P["k"] * (2 * x1 - x2) - P["g"] * x1 ** 3
        a2 = -P["c"] * (v2 - v1) - P["k"] * (x2 - x1) - contact
        return [v1, v2, a1, a2]
    return rhs


@pytest.fixture
def user_backend():
    """A user's own backend and settings: the session must leave both as they were."""
    before = matplotlib.get_backend()
    matplotlib.use("svg", force=True)
    rc = dict(matplotlib.rcParams)
    yield rc
    matplotlib.use(before, force=True)


def test_python_session_from_model_to_mat_file(user_backend, tmp_path):
    # --- the notebook, as a user types it
    system = contin.System(
        dofs=["x1", "x2"], parameters={**P, "w": 1.5},
        mass=np.eye(2), damping=[["2*c", "-c"], ["-c", "c"]], stiffness=[["2*k", "-k"], ["-k", "k"]],
        forces=[{"dof": "x1", "expr": "g*x1**3"},
                {"type": "gap", "dof": "x2", "clearance": "d", "stiffness": "kc", "sides": "+"}],
        excitation=[{"dof": "x1", "expr": "F*cos(tau)"}], frequency="w")
    result = contin.frequency_response(system, parameter="w", range=[1.52, 1.68], harmonics=5, samples=128,
                                       stability="hill", switch=["pd"])
    df = result.to_dataframe()
    result.save(tmp_path / "run", exports=["mat"])
    ax = result.plot()
    # ---

    assert result.status == "complete", result.message
    assert matplotlib.get_backend() == "svg"
    assert dict(matplotlib.rcParams) == user_backend
    # the period doubling of the harmonic branch, and the 1/2 subharmonic switched there
    harmonic = result.branches[0]
    pd_points = [s for s in harmonic.special_points if s.kind == "pd"]
    assert pd_points and all(s.interval[0] <= s.interval[1] for s in result.special_points)
    sub = [b for b in result.branches if b.nu == 2]
    assert sub and all(b.status == "range_end" for b in sub)
    assert min(abs(b.parameter[0] - pd_points[0].parameter) for b in sub) < 0.02
    # stability comes with every point, consistent with the multipliers
    assert set(np.unique(harmonic.stable)) <= {0, 1}
    assert np.all((harmonic.stable == 1) == (harmonic["max_multiplier"] <= 1.0 + 1e-9))
    # the table, the .mat file and the coefficients agree
    assert len(df) == sum(len(b) for b in result.branches) and "amp_x1" in df.columns
    mat = scipy.io.loadmat(tmp_path / "run" / "results.mat", squeeze_me=True, struct_as_record=False)
    assert np.allclose(mat["branches"].amp_x1, df["amp_x1"].to_numpy())
    assert np.allclose(mat["coefficients"], result.coefficients())
    assert ax.get_xlabel() and "w" != ax.get_xlabel()
    import matplotlib.pyplot as plt

    plt.close(ax.figure)  # the user's pyplot figure: the tests after this one expect none open

    # truth from outside: scipy integrates the hand-written equations over one period from a
    # subharmonic point and lands on the harmonic-balance orbit
    b = sub[0]
    row, w = b.rows[len(b) // 2], float(b.parameter[len(b) // 2])
    t, x, xdot = result.time_history(row, samples=200)
    sol = solve_ivp(_equations_of_motion(w), (0.0, 4 * np.pi / w), [*x[0], *xdot[0]], rtol=1e-10, atol=1e-12,
                    dense_output=True, max_step=0.02)
    assert np.abs(sol.sol(t)[:2].T - x).max() < 1e-2 * np.abs(x).max()
