"""The generated source of the variational loop of :mod:`contin.timedomain.variational` and of its model functions.

``flow`` integrates the state and, when asked, ``Phi = dy/dz`` with the row
``g = d t_start / dz`` of the current sub-step's start time; the algebra is in
the docstring of :mod:`contin.timedomain.variational`. The code is appended to
the model's simulation module and its Jacobian functions
(:func:`jacobian_functions`, from the elements' compiled forms: ``jac`` and
``rhs_tau``, the right-hand side's derivatives in the state and the phase; the
switching functions' gradients ``switch_grad`` are in the simulation module).
"""

from __future__ import annotations

from contin.timedomain.integrator_source import MINV_TIMES_R

__all__ = ["NO_JACOBIAN", "VARIATIONAL", "jacobian_functions"]


VARIATIONAL = '''

@njit(cache=True, error_model="numpy", inline="always")
def _scratch(n2):
    # the model functions' work arrays: X, V, TAU, F, DUM, DX, DXD, R and B (N x 2N)
    return (np.zeros((1, N)), np.zeros((1, N)), np.zeros(1), np.zeros((1, N)), np.zeros((1, N, N)),
            np.zeros((1, N, N)), np.zeros((1, N, N)), np.zeros(N), np.zeros((N, n2)))


@njit(cache=True, error_model="numpy", inline="always")
def _graze(tx, tv, graze):
    # keep, per switching function, the turn nearest to zero
    for j in range(NS):
        if tx[j] >= 0.0 and abs(tv[j]) < abs(graze[j]):
            graze[j] = tv[j]


@njit(cache=True, error_model="numpy", inline="always")
def _apply(B, P, Q):
    # Q = A P with A = [[0, I], [B]] (P (2N, columns))
    n2 = 2 * N
    nc = P.shape[1]
    for r in range(N):
        for c in range(nc):
            Q[r, c] = P[N + r, c]
    for r in range(N):
        for c in range(nc):
            a = 0.0
            for q in range(n2):
                a += B[r, q] * P[q, c]
            Q[N + r, c] = a


@njit(cache=True, error_model="numpy", inline="always")
def _applyv(B, v, out):
    # out = A v with A = [[0, I], [B]]
    n2 = 2 * N
    for r in range(N):
        out[r] = v[N + r]
        a = 0.0
        for q in range(n2):
            a += B[r, q] * v[q]
        out[N + r] = a


@njit(cache=True, error_model="numpy")
def step_times(y, tau0, dtau, hs, om, p, Minv, C, K, cst, mode, ta, tb):
    """dR/dt0 (ta) and dR/dt1 (tb) of the RK4 step R of length hs = t1 - t0 from phase tau0 = om t0.

    dtau = om hs (as the loop has it). The RK4 formulas differentiated exactly: stage i at
    Y_i = y + c_i hs k_{i-1}, phase tau0 + c_i om hs (c = 0, 1/2, 1/2, 1), so with J_i, ft_i the
    right-hand side's derivatives in y and tau there, d k_i / d t1 = J_i c_i (k_{i-1} + hs d k_{i-1} / d t1)
    + c_i om ft_i and, at fixed hs, d k_i / d t0 = J_i c_i hs d k_{i-1} / d t0 + om ft_i.
    """
    n2 = 2 * N
    X, V, TAU, F, DUM, DX, DXD, R, B = _scratch(n2)
    kp = np.zeros(n2)
    kc = np.zeros(n2)
    yt = np.empty(n2)
    ft = np.zeros(n2)
    vt = np.zeros(n2)
    db = np.zeros(n2)
    da = np.zeros(n2)
    sk = np.zeros(n2)
    sdb = np.zeros(n2)
    sda = np.zeros(n2)
    for i in range(n2):
        yt[i] = y[i]
    for st in range(4):
        ct = 0.0 if st == 0 else (0.5 if st < 3 else 1.0)
        wt = 2.0 if (st == 1 or st == 2) else 1.0
        rhs(yt, tau0 + ct * dtau, p, Minv, C, K, cst, mode, X, V, TAU, F, DUM, R, kc)
        jac(yt, tau0 + ct * dtau, p, Minv, C, K, cst, mode, X, V, TAU, F, DX, DXD, B)
        rhs_tau(yt, tau0 + ct * dtau, p, Minv, C, K, cst, mode, X, V, TAU, F, R, ft)
        if st == 0:
            for i in range(n2):
                db[i] = 0.0
                da[i] = om * ft[i]
        else:
            for i in range(n2):
                vt[i] = ct * (kp[i] + hs * db[i])
            _applyv(B, vt, db)
            for i in range(n2):
                vt[i] = ct * hs * da[i]
            _applyv(B, vt, da)
            for i in range(n2):
                db[i] += ct * om * ft[i]
                da[i] += om * ft[i]
        for i in range(n2):
            sk[i] += wt * kc[i]
            sdb[i] += wt * db[i]
            sda[i] += wt * da[i]
            kp[i] = kc[i]
        if st < 3:
            cn = 0.5 if st < 2 else 1.0
            for i in range(n2):
                yt[i] = y[i] + cn * hs * kc[i]
    for i in range(n2):
        tb[i] = sk[i] / 6.0 + hs / 6.0 * sdb[i]
        ta[i] = hs / 6.0 * sda[i] - tb[i]


@njit(cache=True, error_model="numpy", nogil=True)
def flow(y, mode, P, k0, k1, S, h, p, Minv, C, K, cst, dC, dK, dcst, rate, max_events, want, L, factors, graze,
         stats):
    """Steps k0..k1-1 on y (2n,), mode (NS,) and, with want, P (2n, 2n); factors every L steps.

    P (2n, 2n + 1): its last column the sensitivity dy/dlambda at fixed phase (dC, dK, dcst the
    derivatives of C, K and cst in lambda, rate = d ln h / d lambda), through the same stages and switches.

    stats: 0 events, 1 unresolved, 2 failing step, 3 steps, 4 trials, 5 switches with n . dR/dt1 = 0.
    Returns 0 = done, 1 = non-finite state or derivative.
    """
    n2 = 2 * N  # a constant: the small loops unrolled
    nc = P.shape[1]  # n2, or n2 + 1 with the sensitivity column
    X, V, TAU, F, DUM, DX, DXD, R, B = _scratch(n2)
    fl = np.zeros(n2)
    q1 = np.empty(n2)
    q2 = np.empty(n2)
    q3 = np.empty(n2)
    q4 = np.empty(n2)
    yt = np.empty(n2)
    ym = np.empty(n2)
    yb = np.empty(n2)
    Q1 = np.empty((n2, nc))
    Q2 = np.empty((n2, nc))
    Q3 = np.empty((n2, nc))
    Q4 = np.empty((n2, nc))
    Pt = np.empty((n2, nc))
    Pm = np.empty((n2, nc))
    # the step's derivatives in its start and end times, dR/dt0 (ta) and dR/dt1 (tb)
    ta = np.zeros(n2)
    tb = np.zeros(n2)
    gz = np.zeros(nc)  # d t_start / dz (and / d lambda) of the current sub-step (zero at grid times)
    hasg = False
    ns = max(NS, 1)
    G = np.zeros((ns, n2))
    s0 = np.zeros(ns)
    sm = np.zeros(ns)
    sb = np.zeros(ns)
    crossed = np.zeros(ns, dtype=np.bool_)
    # dips inside a step and the switching functions' turns, as in the simulation module's integrate
    sp = np.zeros(ns)
    tx = np.zeros(ns)
    tv = np.zeros(ns)
    kb = np.empty(n2)
    # a plain step's turn waits for the slopes at its end, the next step's first stage (pend): its start
    # values ps0, slopes psl (per unit time) and length ph; sl0 the slopes at the current step's start
    sl0 = np.zeros(ns)
    ps0 = np.zeros(ns)
    psl = np.zeros(ns)
    ptx = np.zeros(ns)
    ptv = np.zeros(ns)
    ph = 0.0
    pend = False
    nh = 0
    dphi = 2.0 * np.pi / S
    om = dphi / h  # the phase rate: tau = om t
    if NS > 0:
        switch(y, p, cst, X, V, s0)
    nf = 0
    for k in range(k0, k1):
        kk = k % S
        theta = 0.0
        nev = 0
        searching = False
        finishing = False  # an event located: Phi over the sub-step up to it, then the switch
        a = 0.0
        b = 1.0
        ga = 0.0
        gb = 0.0
        side = 0
        it = 0
        while True:
            frac = 1.0 - theta
            tau0 = (kk + theta) * dphi
            mth = 1.0
            if searching:
                mth = b - gb * (b - a) / (gb - ga)
                if not (mth > a and mth < b):
                    mth = 0.5 * (a + b)
            elif finishing:
                mth = b
            # one call site each (_step is inlined, and every copy costs compile time)
            if searching or not want:
                if not finishing:
                    _step(y, tau0, mth * frac * dphi, mth * frac * h, p, Minv, C, K, cst, mode, X, V, TAU, F, DUM,
                          R, q1, q2, q3, q4, yt, ym)
            else:
                # one RK4 step of the state (bit for bit _step's arithmetic: 1.0 * hs = hs, tau0 + 0.0 * dtau =
                # tau0) and of Phi through the same stages; written out here, not called: a call with thirty
                # array arguments cost about twice the step (measured)
                dtau = mth * frac * dphi
                hs = mth * frac * h
                for i in range(n2):
                    yt[i] = y[i]
                    for c in range(nc):
                        Pt[i, c] = P[i, c]
                for st in range(4):
                    ct = 0.0 if st == 0 else (0.5 if st < 3 else 1.0)
                    kc = q1 if st == 0 else (q2 if st == 1 else (q3 if st == 2 else q4))
                    Qc = Q1 if st == 0 else (Q2 if st == 1 else (Q3 if st == 2 else Q4))
                    rhs(yt, tau0 + ct * dtau, p, Minv, C, K, cst, mode, X, V, TAU, F, DUM, R, kc)
                    jac(yt, tau0 + ct * dtau, p, Minv, C, K, cst, mode, X, V, TAU, F, DX, DXD, B)
                    _apply(B, Pt, Qc)
                    if nc > n2:
                        # the sensitivity's stage: dk = A dY + d f / d lambda (dY carries the step's own
                        # derivative, rate * hs, times the last stage)
                        rhs_lam(yt, tau0 + ct * dtau, Minv, dC, dK, dcst, R, fl)
                        for i in range(n2):
                            Qc[i, n2] += fl[i]
                    if st < 3:
                        cn = 0.5 if st < 2 else 1.0
                        for i in range(n2):
                            yt[i] = y[i] + cn * hs * kc[i]
                            for c in range(nc):
                                Pt[i, c] = P[i, c] + cn * hs * Qc[i, c]
                            if nc > n2:
                                Pt[i, n2] += cn * rate * hs * kc[i]
                for i in range(n2):
                    ym[i] = y[i] + hs / 6.0 * (q1[i] + 2.0 * q2[i] + 2.0 * q3[i] + q4[i])
                    for c in range(nc):
                        Pm[i, c] = P[i, c] + hs / 6.0 * (Q1[i, c] + 2.0 * Q2[i, c] + 2.0 * Q3[i, c] + Q4[i, c])
                    if nc > n2:
                        Pm[i, n2] += rate * hs / 6.0 * (q1[i] + 2.0 * q2[i] + 2.0 * q3[i] + q4[i])
                if finishing or hasg:
                    # the time derivatives only where they enter, a sub-step ending at a switch or starting at
                    # one (a few a period: a call of its own, the stages recomputed)
                    step_times(y, tau0, dtau, hs, om, p, Minv, C, K, cst, mode, ta, tb)
            if DIP and theta == 0.0 and not searching and not finishing:
                # the slopes s' = grad s . y' at the grid step's start (q1 its first stage): the end of the
                # waiting turn, the start of this step's
                switch_grad(y, p, cst, X, V, G)
                for j in range(NS):
                    sl0[j] = _slope(G, j, q1, 1.0)
                if pend:
                    pend = False
                    for j in range(NS):
                        ptx[j], ptv[j] = _hermite(ps0[j], s0[j], psl[j] * ph, sl0[j] * ph)
                    _graze(ptx, ptv, graze)
            if finishing:
                # accept the state just past the surface (yb; the sub-step's own state is the same arithmetic),
                # differentiate the event time and switch the crossing laws
                finishing = False
                if DIP:
                    # the turns of the arc ending here, in its own mode
                    _turns(y, yb, q1, tau0 + b * frac * dphi, b * frac * h, p, Minv, C, K, cst, mode, X, V, TAU, F,
                           DUM, R, kb, G, s0, sb, tx, tv)
                    _graze(tx, tv, graze)
                jev = -1
                dmin = np.inf
                for j in range(NS):
                    if crossed[j]:
                        d = -sb[j] if mode[j] != 0 else sb[j]
                        if d >= 0.0:
                            if d < dmin:
                                jev = j
                                dmin = d
                            mode[j] = 1 - mode[j]
                if want:
                    # Phi <- P Phi + a g^T at the event state; s(y_b(t_e)) = 0 gives dt_e = -n.(..) / n.b
                    for i in range(n2):
                        for c in range(nc):
                            P[i, c] = Pm[i, c] + (ta[i] * gz[c] if hasg else 0.0)
                    den = 0.0
                    if jev >= 0:
                        switch_grad(yb, p, cst, X, V, G)
                        for i in range(n2):
                            den += G[jev, i] * tb[i]
                    if den == 0.0 or not np.isfinite(den):
                        # grazing incidence: the event time taken as fixed
                        stats[5] += 1
                        hasg = False
                        for c in range(nc):
                            gz[c] = 0.0
                    else:
                        for c in range(nc):
                            w = 0.0
                            for i in range(n2):
                                w += G[jev, i] * P[i, c]
                            gz[c] = -w / den
                        for i in range(n2):
                            for c in range(nc):
                                P[i, c] += tb[i] * gz[c]
                        hasg = True
                for i in range(n2):
                    y[i] = yb[i]
                for j in range(NS):
                    s0[j] = sb[j]
                theta = theta + b * frac
                nev += 1
                stats[0] += 1
                if theta >= 1.0 - 1e-12:
                    break
                continue
            if NS == 0:
                for i in range(n2):
                    y[i] = ym[i]
                if want:
                    for i in range(n2):
                        for c in range(nc):
                            P[i, c] = Pm[i, c]
                stats[3] += 1
                break
            switch(ym, p, cst, X, V, sm)
            if searching:
                stats[4] += 1
                it += 1
                gm = _gfun(sm, mode, crossed)
                if gm >= 0.0:
                    b = mth
                    gb = gm
                    for i in range(n2):
                        yb[i] = ym[i]
                    for j in range(NS):
                        sb[j] = sm[j]
                    if side == 1:
                        ga *= 0.5
                    side = 1
                else:
                    a = mth
                    ga = gm
                    if side == -1:
                        gb *= 0.5
                    side = -1
                if b - a > 1e-13 and it < 200:
                    continue
                searching = False
                finishing = True
                continue
            stats[3] += 1
            ncross = 0
            for j in range(NS):
                crossed[j] = (sm[j] > 0.0) != (mode[j] != 0)
                if crossed[j]:
                    ncross += 1
            near = ncross == 0 and DIP and nev < max_events and _near(s0, sm, sp, nh, theta)
            if ncross == 0 and DIP and theta == 0.0 and not near:
                # no dip possible: the turn is only the graze's, and waits for the next step's slopes (the
                # same state: one switch gradient and one right-hand side a step fewer)
                pend = True
                ph = frac * h
                for j in range(NS):
                    ps0[j] = s0[j]
                    psl[j] = sl0[j]
            elif ncross == 0 and DIP:
                _turns_in(y, ym, q1, tau0 + frac * dphi, frac * h, p, Minv, C, K, cst, mode, X, V, TAU, F, DUM, R, kb,
                       G, s0, sm, tx, tv)
                if near:
                    # as the simulation module's integrate, bit for bit (the same trials from the same state)
                    b = _probe(y, tau0, frac * dphi, frac * h, p, Minv, C, K, cst, mode, X, V, TAU, F, DUM, R, q1,
                               s0, ym, sm, tx, tv, crossed, yb, sb, stats)
                    if b > 0.0:
                        a = 0.0
                        ga = _gfun(s0, mode, crossed)
                        gb = _gfun(sb, mode, crossed)
                        side = 0
                        it = 0
                        searching = True
                        continue
                _graze(tx, tv, graze)
            if ncross == 0 or nev >= max_events:
                nh = nh + 1 if ncross == 0 and nev == 0 else 0
                for i in range(n2):
                    y[i] = ym[i]
                if want:
                    # a sub-step ending at the grid time: Phi <- P Phi + a g^T
                    for i in range(n2):
                        for c in range(nc):
                            P[i, c] = Pm[i, c] + (ta[i] * gz[c] if hasg else 0.0)
                for j in range(NS):
                    sp[j] = s0[j]
                    s0[j] = sm[j]
                if ncross != 0:
                    # too many events in one step: take it as it is, follow the state's own mode
                    for j in range(NS):
                        mode[j] = 1 if sm[j] > 0.0 else 0
                    stats[1] += 1
                break
            ga = _gfun(s0, mode, crossed)
            gb = _gfun(sm, mode, crossed)
            if ga > 0.0:
                # the start is already past a surface (round-off at an earlier event): switch there, with the
                # derivative of a located event of zero length (R = I, dR/dt1 = -dR/dt0 = f-), the limit of
                # the located one
                for j in range(NS):
                    if crossed[j]:
                        new = 1 if s0[j] > 0.0 else 0
                        if new != mode[j] and want:
                            rhs(y, tau0, p, Minv, C, K, cst, mode, X, V, TAU, F, DUM, R, q1)
                            switch_grad(y, p, cst, X, V, G)
                            den = 0.0
                            for i in range(n2):
                                den += G[j, i] * q1[i]
                            if den == 0.0 or not np.isfinite(den):
                                stats[5] += 1
                            else:
                                for c in range(nc):
                                    w = 0.0
                                    for i in range(n2):
                                        w += G[j, i] * P[i, c]
                                    w /= den
                                    # Phi - f- g^T + f- dt_e^T with dt_e = g - n.Phi / n.f-
                                    for i in range(n2):
                                        P[i, c] -= q1[i] * w
                                    gz[c] = (gz[c] if hasg else 0.0) - w
                                hasg = True
                        mode[j] = new
                nev += 1
                stats[1] += 1
                continue
            a = 0.0
            b = 1.0
            side = 0
            it = 0
            for i in range(n2):
                yb[i] = ym[i]
            for j in range(NS):
                sb[j] = sm[j]
            searching = True
        # the next step starts at a grid time
        if hasg:
            hasg = False
            for c in range(nc):
                gz[c] = 0.0
        for i in range(n2):
            if not np.isfinite(y[i]):
                stats[2] = k + 1
                return 1
        if want and (k + 1 - k0) % L == 0:
            for i in range(n2):
                for c in range(nc):
                    if not np.isfinite(P[i, c]):
                        stats[2] = k + 1
                        return 1
                    factors[nf, i, c] = P[i, c]
                    P[i, c] = 1.0 if i == c else 0.0
            nf += 1
    if pend:
        # the last step's turn: the slopes at the run's end
        rhs(y, (k1 % S) * dphi, p, Minv, C, K, cst, mode, X, V, TAU, F, DUM, R, kb)
        switch_grad(y, p, cst, X, V, G)
        for j in range(NS):
            ptx[j], ptv[j] = _hermite(ps0[j], s0[j], psl[j] * ph, _slope(G, j, kb, ph))
        _graze(ptx, ptv, graze)
    return 0
'''


# stand-ins for a model with an element without Jacobian lines: the state-only loop compiles, never calls them
NO_JACOBIAN = '''

@njit(cache=True)
def jac(y, tau, p, Minv, C, K, cst, mode, X, V, TAU, F, DX, DXD, B):
    return


@njit(cache=True)
def rhs_tau(y, tau, p, Minv, C, K, cst, mode, X, V, TAU, F, R, out):
    return


@njit(cache=True)
def rhs_lam(y, tau, Minv, dC, dK, dcst, R, out):
    return
'''



def jacobian_functions(jac: list, ftau: list, etau: list, elam: list = ()) -> str:
    """The source of ``jac``, ``rhs_tau`` and ``rhs_lam`` around the elements' lines.

    Parameters
    ----------
    jac : list of str
        Lines accumulating ``d f_nl / dx`` into ``DX`` and ``d f_nl / dx'``
        into ``DXD`` (indented, as all of them).
    ftau : list of str
        Lines accumulating ``d f_nl / d tau`` into ``F``.
    etau : list of str
        Lines accumulating ``d f_ext / d tau`` into ``R``.
    elam : list of str
        Lines accumulating ``d f_ext / d lambda`` into ``R`` (the excitations' lines with the constants'
        derivatives ``dcst``; only excitations linear in their constants have them).

    Returns
    -------
    str
        The two functions
        (:meth:`contin.timedomain.integrator.CompiledModel.jacobian_source`).
    """
    src = [
        "",
        "",
        '@njit(cache=True, error_model="numpy", inline="always")',
        "def jac(y, tau, p, Minv, C, K, cst, mode, X, V, TAU, F, DX, DXD, B):",
        "    # B = -M^-1 [K + df/dx, C + df/dx'] in the frozen contact mode (F is scratch)",
        "    for i in range(N):",
        "        X[0, i] = y[i]",
        "        V[0, i] = y[N + i]",
        "        F[0, i] = 0.0",
        "        for j in range(N):",
        "            DX[0, i, j] = 0.0",
        "            DXD[0, i, j] = 0.0",
        "    TAU[0] = tau",
    ] + jac + [
        "    for i in range(N):",
        "        for j in range(N):",
        "            if MDIAG:",
        "                B[i, j] = 0.0 - Minv[i, i] * (K[i, j] + DX[0, i, j])",
        "                B[i, N + j] = 0.0 - Minv[i, i] * (C[i, j] + DXD[0, i, j])",
        "            else:",
        "                a = 0.0",
        "                b = 0.0",
        "                for q in range(N):",
        "                    a -= Minv[i, q] * (K[q, j] + DX[0, q, j])",
        "                    b -= Minv[i, q] * (C[q, j] + DXD[0, q, j])",
        "                B[i, j] = a",
        "                B[i, N + j] = b",

        "",
        "",
        '@njit(cache=True, error_model="numpy", inline="always")',
        "def rhs_tau(y, tau, p, Minv, C, K, cst, mode, X, V, TAU, F, R, out):",
        "    # out = d y' / d tau = (0, M^-1 (d f_ext / d tau - d f_nl / d tau)) in the frozen mode",
        "    for i in range(N):",
        "        X[0, i] = y[i]",
        "        V[0, i] = y[N + i]",
        "        F[0, i] = 0.0",
        "    TAU[0] = tau",
    ] + ftau + [
        "    for i in range(N):",
        "        R[i] = -F[0, i]",
    ] + etau + _ACCELERATION + [
        "",
        "",
        '@njit(cache=True, error_model="numpy", inline="always")',
        "def rhs_lam(y, tau, Minv, dC, dK, dcst, R, out):",
        "    # out = d y' / d lambda at fixed y and tau, (0, M^-1 (d f_ext / d lambda - dC v - dK x)): the mass and",
        "    # the force laws do not depend on lambda (parameter_sensitivity checks it)",
        "    for i in range(N):",
        "        s = 0.0",
        "        for j in range(N):",
        "            s -= dC[i, j] * y[N + j] + dK[i, j] * y[j]",
        "        R[i] = s",
    ] + list(elam) + _ACCELERATION
    return "\n".join(src) + "\n"


#: the generated lines ``out = (0, M^-1 R)``: a derivative of the right-hand side whose velocity rows vanish
_ACCELERATION = [
    "    for i in range(N):",
    "        out[i] = 0.0",
] + MINV_TIMES_R
