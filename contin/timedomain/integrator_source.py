"""The generated source of the simulation module's integrator loop (:mod:`contin.timedomain.integrator`).

``integrate`` takes RK4 steps with the contact mode frozen over each step,
locates the switches by Illinois iterations on the step fraction, and finds a
dip through a surface inside a step from the cubic through the switching
functions' values and slopes at its ends (``_turns``, ``_probe``); the
algebra is in the docstring of :mod:`contin.timedomain.integrator`. The
variational loop (:mod:`contin.timedomain.variational_source`) calls the same
``_turns``, ``_near`` and ``_probe``, so both take the same decisions bit for
bit. The code is appended to the model's generated functions ``rhs``,
``switch`` and ``switch_grad``.
"""

from __future__ import annotations

__all__ = ["INTEGRATOR", "MINV_TIMES_R"]


#: the generated lines ``out[N + i] = (M^-1 R)[i]`` inside a loop over ``i`` (a diagonal mass: one product)
MINV_TIMES_R = [
    "        if MDIAG:",
    "            out[N + i] = Minv[i, i] * R[i]",
    "        else:",
    "            a = 0.0",
    "            for j in range(N):",
    "                a += Minv[i, j] * R[j]",
    "            out[N + i] = a",
]


INTEGRATOR = '''

@njit(cache=True, error_model="numpy", inline="always")
def _step(y, tau0, dtau, hs, p, Minv, C, K, cst, mode, X, V, TAU, F, DUM, R, k1, k2, k3, k4, yt, out):
    # one classical RK4 step of length hs (phase advance dtau) in the frozen mode
    n2 = 2 * N
    rhs(y, tau0, p, Minv, C, K, cst, mode, X, V, TAU, F, DUM, R, k1)
    for i in range(n2):
        yt[i] = y[i] + 0.5 * hs * k1[i]
    rhs(yt, tau0 + 0.5 * dtau, p, Minv, C, K, cst, mode, X, V, TAU, F, DUM, R, k2)
    for i in range(n2):
        yt[i] = y[i] + 0.5 * hs * k2[i]
    rhs(yt, tau0 + 0.5 * dtau, p, Minv, C, K, cst, mode, X, V, TAU, F, DUM, R, k3)
    for i in range(n2):
        yt[i] = y[i] + hs * k3[i]
    rhs(yt, tau0 + dtau, p, Minv, C, K, cst, mode, X, V, TAU, F, DUM, R, k4)
    for i in range(n2):
        out[i] = y[i] + hs / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])


@njit(cache=True)
def _gfun(s, mode, crossed):
    # > 0 once any crossed switching function is past its surface
    g = -np.inf
    for j in range(NS):
        if crossed[j]:
            d = -s[j] if mode[j] != 0 else s[j]
            if d > g:
                g = d
    return g


@njit(cache=True, error_model="numpy", inline="always")
def _hermite(sa, sb, da, db):
    # the extremum on [0, 1] of the cubic with end values sa, sb and end slopes da, db: (fraction, value);
    # fraction -1 where the slopes keep their sign (p' = A x^2 + B x + da, p'(1) = db)
    if da * db > 0.0 or (da == 0.0 and db == 0.0):
        return -1.0, 0.0
    A = 6.0 * (sa - sb) + 3.0 * (da + db)
    B = 6.0 * (sb - sa) - 4.0 * da - 2.0 * db
    r1 = -1.0
    r2 = -1.0
    if A == 0.0:
        if B != 0.0:
            r1 = -da / B
    else:
        disc = max(B * B - 4.0 * A * da, 0.0)
        q = -0.5 * (B + (np.sqrt(disc) if B >= 0.0 else -np.sqrt(disc)))
        r1 = q / A
        r2 = da / q if q != 0.0 else r1
    xb = -1.0
    vb = 0.0
    for r in (r1, r2):
        if -1e-9 <= r <= 1.0 + 1e-9:
            x = min(max(r, 0.0), 1.0)
            v = (sa * (1.0 + x * x * (2.0 * x - 3.0)) + da * x * (1.0 - x) * (1.0 - x)
                 + sb * x * x * (3.0 - 2.0 * x) + db * x * x * (x - 1.0))
            if xb < 0.0 or abs(v) < abs(vb):
                xb = x
                vb = v
    return xb, vb


@njit(cache=True, error_model="numpy", inline="always")
def _slope(G, j, f, hs):
    # hs s_j' = hs grad s_j . y': the slope of switching function j per unit fraction of a step of length hs
    d = 0.0
    for i in range(f.shape[0]):
        d += G[j, i] * f[i]
    return hs * d


@njit(cache=True, error_model="numpy")
def _turns(y, yb, ka, tau1, hs, p, Minv, C, K, cst, mode, X, V, TAU, F, DUM, R, kb, G, sa, sb, tx, tv):
    # the call for the rare sites: a call with two dozen array arguments costs about as much as its work
    _turns_in(y, yb, ka, tau1, hs, p, Minv, C, K, cst, mode, X, V, TAU, F, DUM, R, kb, G, sa, sb, tx, tv)


@njit(cache=True, error_model="numpy", inline="always")
def _turns_in(y, yb, ka, tau1, hs, p, Minv, C, K, cst, mode, X, V, TAU, F, DUM, R, kb, G, sa, sb, tx, tv):
    # per switching function, the extremum inside a (sub-)step of the cubic through s and s' = grad s . y' at
    # its ends (y with ka = y'(y), yb at phase tau1, both in the frozen mode): its fraction tx (-1: none), value tv
    switch_grad(y, p, cst, X, V, G)
    for j in range(NS):
        tx[j] = _slope(G, j, ka, hs)
    rhs(yb, tau1, p, Minv, C, K, cst, mode, X, V, TAU, F, DUM, R, kb)
    switch_grad(yb, p, cst, X, V, G)
    for j in range(NS):
        tx[j], tv[j] = _hermite(sa[j], sb[j], tx[j], _slope(G, j, kb, hs))


@njit(cache=True, error_model="numpy", inline="always")
def _near(s0, sm, sp, nh, theta):
    # a dip through a surface inside the step is possible: near the start of a run or after an event, or a
    # switching function within twice its second difference of zero (16 times the reach of a parabola's turn)
    if theta > 0.0 or nh < 2:
        return True
    for j in range(NS):
        if min(abs(s0[j]), abs(sm[j])) <= 2.0 * abs(sm[j] - 2.0 * s0[j] + sp[j]):
            return True
    return False


@njit(cache=True, error_model="numpy", inline="always")
def _dip(tx, tv, mode, crossed):
    # the first turn past a surface (fraction in (0, 1)), its functions marked crossed; -1 for none
    x = -1.0
    for j in range(NS):
        crossed[j] = tx[j] > 0.0 and tx[j] < 1.0 and ((tv[j] > 0.0) != (mode[j] != 0))
        if crossed[j] and (x < 0.0 or tx[j] < x):
            x = tx[j]
    return x


@njit(cache=True, error_model="numpy")
def _probe(y, tau0, dtau, hs, p, Minv, C, K, cst, mode, X, V, TAU, F, DUM, R, ka, s0, ym, sm, tx, tv, crossed, yb,
           sb, stats):
    # A turn predicted past a surface (_dip marked its functions crossed): RK4 trials from y in the frozen mode at
    # the turn, refined by the cubic on the part of the step where the slope changes sign (up to four trials).
    # Returns the fraction of a trial past the surface (its state in yb, switching values in sb), or -1.
    n2 = 2 * N
    x = _dip(tx, tv, mode, crossed)
    if x <= 0.0:
        return -1.0
    jj = 0
    for j in range(NS):
        if crossed[j] and tx[j] == x:
            jj = j
    q1 = np.empty(n2)
    q2 = np.empty(n2)
    q3 = np.empty(n2)
    q4 = np.empty(n2)
    yt = np.empty(n2)
    kb = np.empty(n2)
    G = np.zeros((max(NS, 1), n2))
    # the bracket of the turn: fractions, values and slopes (per unit fraction) of function jj
    lo = 0.0
    hi = 1.0
    switch_grad(y, p, cst, X, V, G)
    dl = _slope(G, jj, ka, hs)
    vl = s0[jj]
    rhs(ym, tau0 + dtau, p, Minv, C, K, cst, mode, X, V, TAU, F, DUM, R, kb)
    switch_grad(ym, p, cst, X, V, G)
    dh = _slope(G, jj, kb, hs)
    vh = sm[jj]
    for trial in range(4):
        _step(y, tau0, x * dtau, x * hs, p, Minv, C, K, cst, mode, X, V, TAU, F, DUM, R, q1, q2, q3, q4, yt, yb)
        switch(yb, p, cst, X, V, sb)
        stats[4] += 1
        if _gfun(sb, mode, crossed) >= 0.0:
            return x
        if trial == 3:
            break
        rhs(yb, tau0 + x * dtau, p, Minv, C, K, cst, mode, X, V, TAU, F, DUM, R, kb)
        switch_grad(yb, p, cst, X, V, G)
        d = _slope(G, jj, kb, hs)
        if (d > 0.0) == (dl > 0.0):
            lo = x
            vl = sb[jj]
            dl = d
        else:
            hi = x
            vh = sb[jj]
            dh = d
        u, v = _hermite(vl, vh, dl * (hi - lo), dh * (hi - lo))
        if u < 0.0 or ((v > 0.0) == (mode[jj] != 0)):
            break
        x = lo + u * (hi - lo)
        if not (x > lo and x < hi):
            break
    return -1.0


@njit(cache=True, error_model="numpy", nogil=True)
def integrate(y, mode, k0, k1, S, h, p, Minv, C, K, cst, locate, max_events, rec_start, rec_every,
              out_y, sec_y, stats):
    """Steps k0..k1-1 in place on y (2n,) and mode (NS,); 0 = done, 1 = non-finite state."""
    n2 = 2 * N
    X = np.zeros((1, N))
    V = np.zeros((1, N))
    TAU = np.zeros(1)
    F = np.zeros((1, N))
    DUM = np.zeros((1, N, N))
    R = np.zeros(N)
    q1 = np.empty(n2)
    q2 = np.empty(n2)
    q3 = np.empty(n2)
    q4 = np.empty(n2)
    yt = np.empty(n2)
    ym = np.empty(n2)
    yb = np.empty(n2)
    ns = max(NS, 1)
    s0 = np.zeros(ns)
    sm = np.zeros(ns)
    sb = np.zeros(ns)
    crossed = np.zeros(ns, dtype=np.bool_)
    # a dip through a surface and back inside one step: history, the turns' cubic, the full step kept
    sp = np.zeros(ns)
    tx = np.zeros(ns)
    tv = np.zeros(ns)
    G = np.zeros((ns, n2))
    nh = 0
    dphi = 2.0 * np.pi / S
    if NS > 0:
        switch(y, p, cst, X, V, s0)
    for k in range(k0, k1):
        kk = k % S
        theta = 0.0  # fraction of the step done
        nev = 0
        searching = False
        a = 0.0
        b = 1.0
        ga = 0.0
        gb = 0.0
        side = 0
        it = 0
        while True:
            frac = 1.0 - theta
            tau0 = (kk + theta) * dphi
            # one trial per pass: the rest of the step, or a point of the Illinois iteration on a crossing
            mth = 1.0
            if searching:
                mth = b - gb * (b - a) / (gb - ga)
                if not (mth > a and mth < b):
                    mth = 0.5 * (a + b)
            # the only call site of _step: it is inlined, and every copy costs compile time
            _step(y, tau0, mth * frac * dphi, mth * frac * h, p, Minv, C, K, cst, mode, X, V, TAU, F, DUM, R,
                  q1, q2, q3, q4, yt, ym)
            if NS == 0:
                for i in range(n2):
                    y[i] = ym[i]
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
                # accept the state just past the surface and switch the crossing laws
                searching = False
                for j in range(NS):
                    if crossed[j]:
                        d = -sb[j] if mode[j] != 0 else sb[j]
                        if d >= 0.0:
                            mode[j] = 1 - mode[j]
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
            stats[3] += 1
            ncross = 0
            for j in range(NS):
                crossed[j] = (sm[j] > 0.0) != (mode[j] != 0)
                if crossed[j]:
                    ncross += 1
            if ncross == 0 and DIP and locate and nev < max_events and _near(s0, sm, sp, nh, theta):
                _turns(y, ym, q1, tau0 + frac * dphi, frac * h, p, Minv, C, K, cst, mode, X, V, TAU, F, DUM, R, q2,
                       G, s0, sm, tx, tv)
                b = _probe(y, tau0, frac * dphi, frac * h, p, Minv, C, K, cst, mode, X, V, TAU, F, DUM, R, q1, s0,
                           ym, sm, tx, tv, crossed, yb, sb, stats)
                if b > 0.0:
                    # a dip through a surface: locate its first crossing in [0, b]
                    a = 0.0
                    ga = _gfun(s0, mode, crossed)
                    gb = _gfun(sb, mode, crossed)
                    side = 0
                    it = 0
                    searching = True
                    continue
            if ncross == 0:
                nh = nh + 1 if nev == 0 else 0
                for i in range(n2):
                    y[i] = ym[i]
                for j in range(NS):
                    sp[j] = s0[j]
                    s0[j] = sm[j]
                break
            if (not locate) or nev >= max_events:
                # take the step as it is and follow the state's own contact state
                nh = 0
                for i in range(n2):
                    y[i] = ym[i]
                for j in range(NS):
                    s0[j] = sm[j]
                    mode[j] = 1 if sm[j] > 0.0 else 0
                if locate:
                    stats[1] += 1
                break
            ga = _gfun(s0, mode, crossed)
            gb = _gfun(sm, mode, crossed)
            if ga > 0.0:
                # the start is already past a surface (round-off at an earlier event): resynchronise
                for j in range(NS):
                    if crossed[j]:
                        mode[j] = 1 if s0[j] > 0.0 else 0
                nev += 1
                stats[1] += 1
                continue
            # bracket [0, 1] of the remaining step: locate the first crossing in the frozen mode
            a = 0.0
            b = 1.0
            side = 0
            it = 0
            for i in range(n2):
                yb[i] = ym[i]
            for j in range(NS):
                sb[j] = sm[j]
            searching = True
        for i in range(n2):
            if not np.isfinite(y[i]):
                stats[2] = k + 1
                return 1
        kn = k + 1
        if kn % S == 0:
            for i in range(n2):
                sec_y[kn // S, i] = y[i]
        if kn >= rec_start and (kn - rec_start) % rec_every == 0:
            r = (kn - rec_start) // rec_every
            for i in range(n2):
                out_y[r, i] = y[i]
    return 0
'''
