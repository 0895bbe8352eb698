#!/usr/bin/env python3
"""Finite-element reference for a plane-strain elastic disk squeezed between two rigid,
frictionless, flat plates (softgrain issue #4: is the MPM's nu-dependence physics?).

Problem
-------
Disk of radius R, plane strain, symmetric loading by two rigid frictionless plates.
Plate gap = 2R exp(-eps), total approach delta = 2R (1 - exp(-eps)).  F = force per unit
thickness on one plate.  E* = E/(1-nu^2) is held fixed while nu varies.

Model
-----
* Quarter disk (x >= 0, y >= 0): u_x = 0 on x = 0, u_y = 0 on y = 0; the top plate sits
  at y = R - delta/2.  The full plate force is twice the contact force of the quarter.
* Mesh: polar (r, psi) grid, psi = angle from the vertical (psi = 0 at the contact point),
  9-node Lagrange quadrilaterals (Q9, isoparametric: the mid-edge nodes of the rim lie on
  the exact circle).  The grid is uniform (square elements) near the contact, in
  0 <= psi <= 0.26 rad and to a depth of 0.06 R, and graded geometrically elsewhere.  The
  row of elements at r = 0 is collapsed onto the centre node.  Refinement halves every
  element, so the meshes are nested.  "n_b" = number of elements across the contact
  half-width b of the eps = 0.02 solution (b ~ 0.114 R); at eps = 0.05 b is 1.7x larger.
* Elements:  "Q9"    displacement Q9, full 3x3 Gauss;
             "Q2P1"  mixed Q9 displacement / discontinuous linear (1, x, y) pressure
                     (the LBB-stable Q2/P1 pair), pressure condensed per element:
                     K = int B^T D_dev B + kappa G^T M^-1 G.  Used as the locking check.
* Small-strain contact (Signorini, frictionless, node-to-plate): for every rim node in
  0 <= psi <= 0.25 rad the constraint is u_y <= y_plate - Y.  K (symmetry BCs only) is
  non-singular, so the problem is reduced exactly to the candidate nodes with the
  compliance matrix Cm = S K^-1 S^T (one sparse factorisation, m solves).  The remaining
  LCP  lam >= 0, gap = Cm lam - d >= 0, lam.gap = 0  (lam = downward nodal contact forces,
  d = initial overlap) is the KKT system of  min 1/2 lam^T Cm lam - d^T lam,  lam >= 0,
  solved exactly by non-negative least squares on the Cholesky factor of Cm.  (Equivalent
  to the active-set iteration: a node is in contact iff it would cross the plate, released
  iff its reaction would be tensile.)
* Finite strain: total-Lagrangian, plane strain (F33 = 1), with the same small-strain
  Lame constants:
     neo-Hookean  W = mu/2 (tr C - 2) - mu ln J + lam/2 (ln J)^2   (the MPM's law),
     St Venant-Kirchhoff  S = lam tr(E) I + 2 mu E.
  Newton-Raphson with a primal-dual active set on the same candidate nodes, contact with
  the deformed position (Y + u_y <= y_plate: the plate is flat and frictionless, so this
  is again a bound on u_y).  Started from the linear solution.  Displacement Q9 elements
  (the linear runs show what locking remains at nu = 0.49).
* Validation: (a) uniform radial pressure (exact Lame solution); (b) the disk loaded by a
  prescribed Hertz pressure on two small opposite arcs: centre stresses against the
  point-load disk values sigma_x = F/(pi R), sigma_y = -3F/(pi R), and the change of the
  vertical diameter against Johnson's (A) with the Michell-series correction
  (C_nu = 1/3) from bench/disk-contact-nu.md.  The pressure is applied either normal to
  the circle (the .md's set-up) or vertically (what a frictionless flat plate does).
* Why the linear flat-plate result has no nu at fixed E* (see disk-fe-reference.md): in
  plane strain eps = [sigma + k (sigma - tr(sigma) I)]/E*, k = nu/(1-nu), and with the Airy
  function phi, sigma - tr(sigma) I = -grad grad phi.  Stresses of a traction problem on a
  simply connected body do not depend on nu, so the nu part of u is -(k/E*) grad phi.  If
  every boundary traction is vertical (t_x = 0), phi_y is constant along the boundary and
  the nu part of u_y there is a rigid shift: the contact problem is nu-free exactly.
* Side calculation: plates with full stick (infinite friction), linear, incremental.

Units: mm, MPa, N/mm (x 1000 = N/m).  Run:  python3 bench/disk_fe_reference.py [--fine | --window]
(--fine adds the n_b = 80 mesh, Q9 only, to the linear study and a level-3 neo-Hookean
 check: ~6 GB of RAM, ~10 min in all; --window prints only the neo-Hookean ratios averaged
 over eps in [0.01, 0.05], as the MPM example averages them: 15 s).
"""
import os
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import sys
import time
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.optimize import nnls, brentq

R = 5.0                                   # mm
ESTAR = 10.0 / (1.0 - 0.45 ** 2)          # MPa, fixed plane-strain modulus
NUS = (0.30, 0.40, 0.45, 0.49)
EPSS = (0.02, 0.05)
B_REF = 0.114 * R                         # contact half-width at eps = 0.02 (mesh sizing)
PSI_CAND = 0.25                           # candidate contact nodes: psi <= this (rad)


def approach(eps):
    return 2.0 * R * (1.0 - np.exp(-eps))


def lame(nu):
    E = ESTAR * (1.0 - nu * nu)
    return E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))


# ----------------------------------------------------------------------------- analytic
def johnson_delta(F, b=None):
    """Johnson's (A); b defaults to the Hertz half-width of F."""
    b = np.sqrt(4 * F * R / (np.pi * ESTAR)) if b is None else b
    return 4 * F / (np.pi * ESTAR) * (np.log(4 * R / b) - 0.5)


def michell_delta(F, nu, c=1.0 / 3.0, b=None):
    """(A) plus the first-order Michell-series term of bench/disk-contact-nu.md (formula F)."""
    b = np.sqrt(4 * F * R / (np.pi * ESTAR)) if b is None else b
    return 4 * F / (np.pi * ESTAR) * (np.log(4 * R / b) - 0.5
                                      + c * (1 - 2 * nu) / (1 - nu) * b / R)


def force_from(delta_fn, eps):
    return brentq(lambda F: delta_fn(F) - approach(eps), 1e-6, 20.0, xtol=1e-14)


# ----------------------------------------------------------------------------- mesh
def graded(h0, L_unif, L_tot, q, hmax):
    """Coarse 1D node positions: uniform steps ~h0 on [0, L_unif], then steps growing by q
    (capped at hmax) up to L_tot; the graded part is rescaled to end exactly at L_tot."""
    n_u = max(1, int(round(L_unif / h0)))
    h = L_unif / n_u
    pts = [i * h for i in range(n_u + 1)]
    while pts[-1] < L_tot:
        h = min(h * q, hmax)
        pts.append(pts[-1] + h)
    p = np.array(pts)
    # drop the last point if that makes the rescale factor closer to 1
    if len(p) > n_u + 2 and abs(p[-2] - L_tot) < abs(p[-1] - L_tot):
        p = p[:-1]
    g = p[n_u:]
    p[n_u:] = L_unif + (g - L_unif) * (L_tot - L_unif) / (g[-1] - L_unif)
    return p


def refine(p, times):
    for _ in range(times):
        mid = 0.5 * (p[1:] + p[:-1])
        q = np.empty(2 * len(p) - 1)
        q[0::2], q[1::2] = p, mid
        p = q
    return p


class Mesh:
    """Polar Q9 mesh of the quarter disk; level L has n_b = 5 * 2^L elements across B_REF."""

    def __init__(self, level, b_ref=B_REF, psi_unif=0.26, depth_unif=0.06 * R):
        h0 = b_ref / 5.0
        P = graded(h0 / R, psi_unif, np.pi / 2, 1.25, 0.2)          # angle from vertical
        S = graded(h0, depth_unif, R, 1.25, 0.2 * R)                 # depth below the rim
        self.n_b = 5 * 2 ** level
        Pn, Sn = refine(P, level + 1), refine(S, level + 1)          # Q9 node lines
        Pn[-1] = np.pi / 2
        npsi, nr = len(Pn), len(Sn)
        self.nel_psi, self.nel_r = (npsi - 1) // 2, (nr - 1) // 2
        ids = np.arange(nr * npsi).reshape(nr, npsi)
        ids[-1, :] = (nr - 1) * npsi                                 # centre: one node
        nn = (nr - 1) * npsi + 1
        r = R - Sn
        X = np.zeros((nn, 2))
        rr, pp = np.meshgrid(r[:-1], Pn, indexing="ij")
        X[:-1, 0] = (rr * np.sin(pp)).ravel()
        X[:-1, 1] = (rr * np.cos(pp)).ravel()
        X[np.abs(X) < 1e-14 * R] = 0.0
        X[ids[:, -1], 1] = 0.0                                       # psi = pi/2: y = 0
        self.X = X
        # elements: local node (a, b) -> 3 b + a, a along psi, b along depth
        el = []
        for ej in range(self.nel_r):
            for ei in range(self.nel_psi):
                el.append([ids[2 * ej + b, 2 * ei + a] for b in range(3) for a in range(3)])
        self.el = np.array(el)
        self.nn, self.ndof = nn, 2 * nn
        fixed = np.concatenate([2 * ids[:, 0], 2 * ids[:, -1] + 1])   # u_x on x=0, u_y on y=0
        self.fixed = np.unique(fixed)
        rim = ids[0, :]
        self.rim, self.rim_psi = rim, Pn
        cand = rim[Pn <= PSI_CAND + 1e-12]
        self.cand = cand                                             # ordered from psi = 0
        self.cand_dof = 2 * cand + 1
        self.cand_Y = X[cand, 1]
        self.cand_x = X[cand, 0]
        self.centre = nn - 1
        self._geometry()

    def _geometry(self):
        g = np.array([-np.sqrt(0.6), 0.0, np.sqrt(0.6)])
        w = np.array([5.0, 8.0, 5.0]) / 9.0
        xi, eta = np.meshgrid(g, g, indexing="ij")
        xi, eta = xi.ravel(), eta.ravel()
        W = np.outer(w, w).ravel()
        N, dN = q9_shape(xi, eta)                                    # (ng,9), (ng,9,2)
        Xe = self.X[self.el]                                         # (ne,9,2)
        J = np.einsum("gak,eai->egik", dN, Xe)                       # dx_i/dxi_k
        det = J[..., 0, 0] * J[..., 1, 1] - J[..., 0, 1] * J[..., 1, 0]
        Jinv = np.empty_like(J)
        Jinv[..., 0, 0], Jinv[..., 1, 1] = J[..., 1, 1] / det, J[..., 0, 0] / det
        Jinv[..., 0, 1], Jinv[..., 1, 0] = -J[..., 0, 1] / det, -J[..., 1, 0] / det
        self.G = np.einsum("gak,egki->egai", dN, Jinv)               # dN_a/dX_i
        self.wdet = np.abs(det) * W[None, :]
        self.xg = np.einsum("ga,eai->egi", N, Xe)
        assert np.all(np.abs(det) > 0)
        # element dof numbering (a, i) -> 2 node + i and the CSR pattern (assembled by bincount)
        self.edof = (2 * self.el[:, :, None] + np.arange(2)).reshape(len(self.el), 18)
        rows = np.repeat(self.edof, 18, axis=1).ravel()
        cols = np.tile(self.edof, (1, 18)).ravel()
        key = rows.astype(np.int64) * self.ndof + cols
        ukey, self.inv = np.unique(key, return_inverse=True)
        self.csr_rows, self.csr_cols = ukey // self.ndof, ukey % self.ndof
        self.indptr = np.searchsorted(self.csr_rows, np.arange(self.ndof + 1))

    def assemble(self, Ke):
        data = np.bincount(self.inv, weights=Ke.reshape(-1), minlength=len(self.csr_cols))
        return sp.csr_matrix((data, self.csr_cols, self.indptr), shape=(self.ndof, self.ndof))

    def scatter(self, fe):
        return np.bincount(self.edof.ravel(), weights=fe.reshape(-1), minlength=self.ndof)


def q9_shape(xi, eta):
    def l(t):
        return np.stack([0.5 * t * (t - 1), 1 - t * t, 0.5 * t * (t + 1)], -1)

    def dl(t):
        return np.stack([t - 0.5, -2 * t, t + 0.5], -1)

    Lx, Ly, dLx, dLy = l(xi), l(eta), dl(xi), dl(eta)
    N = (Ly[:, :, None] * Lx[:, None, :]).reshape(len(xi), 9)          # 3 b + a
    dNx = (Ly[:, :, None] * dLx[:, None, :]).reshape(len(xi), 9)
    dNy = (dLy[:, :, None] * Lx[:, None, :]).reshape(len(xi), 9)
    return N, np.stack([dNx, dNy], -1)


# ----------------------------------------------------------------------------- materials
I2 = np.eye(2)


def iso_tensor(lam, mu):
    """lam I(x)I + 2 mu Isym (2D components of the plane-strain elasticity tensor)."""
    return (lam * np.einsum("ij,kl->ijkl", I2, I2)
            + mu * (np.einsum("ik,jl->ijkl", I2, I2) + np.einsum("il,jk->ijkl", I2, I2)))


def material(Fd, lam, mu, model):
    """2nd Piola-Kirchhoff stress S and material tangent dS/dE for deformation gradients Fd."""
    C = np.einsum("...ki,...kj->...ij", Fd, Fd)
    if model == "svk":
        E = 0.5 * (C - I2)
        trE = E[..., 0, 0] + E[..., 1, 1]
        S = lam * trE[..., None, None] * I2 + 2 * mu * E
        CC = np.broadcast_to(iso_tensor(lam, mu), Fd.shape[:-2] + (2, 2, 2, 2))
        return S, CC
    if model == "nh":
        J = Fd[..., 0, 0] * Fd[..., 1, 1] - Fd[..., 0, 1] * Fd[..., 1, 0]
        if np.any(J <= 0):
            raise FloatingPointError("J <= 0")
        Ci = np.linalg.inv(C)
        lnJ = np.log(J)[..., None, None]
        S = mu * (I2 - Ci) + lam * lnJ * Ci
        a = (mu - lam * lnJ)[..., None, None]
        CC = (lam * np.einsum("...ij,...kl->...ijkl", Ci, Ci)
              + a * (np.einsum("...ik,...jl->...ijkl", Ci, Ci)
                     + np.einsum("...il,...jk->...ijkl", Ci, Ci)))
        return S, CC
    raise ValueError(model)


def element_arrays(mesh, u, lam, mu, model):
    """Total-Lagrangian element internal forces (ne,9,2) and tangents (ne,18,18)."""
    ue = u[mesh.edof].reshape(-1, 9, 2)
    Fd = I2 + np.einsum("eai,egaJ->egiJ", ue, mesh.G)
    S, CC = material(Fd, lam, mu, model)
    P = np.einsum("egiI,egIJ->egiJ", Fd, S)
    fe = np.einsum("eg,egiJ,egaJ->eai", mesh.wdet, P, mesh.G)
    A = (np.einsum("ik,egJL->egiJkL", I2, S)
         + np.einsum("egiI,egIJKL,egkK->egiJkL", Fd, CC, Fd, optimize=True))
    GA = np.einsum("eg,egaJ,egiJkL->egaikL", mesh.wdet, mesh.G, A, optimize=True)
    Ke = np.einsum("egaikL,egbL->eaibk", GA, mesh.G, optimize=True).reshape(-1, 18, 18)
    return fe, Ke


def linear_stiffness(mesh, nu, element):
    lam, mu = lame(nu)
    if element == "Q9":
        return element_arrays(mesh, np.zeros(mesh.ndof), lam, mu, "svk")[1]
    # Q2/P1: deviatoric part by full integration + projected volumetric part
    Kdev = element_arrays(mesh, np.zeros(mesh.ndof), -2 * mu / 3, mu, "svk")[1]
    kappa = lam + 2 * mu / 3
    xc = mesh.xg.mean(axis=1, keepdims=True)
    hs = np.sqrt(mesh.wdet.sum(1))[:, None, None]
    p = np.concatenate([np.ones(mesh.xg.shape[:2] + (1,)), (mesh.xg - xc) / hs], -1)  # (ne,ng,3)
    M = np.einsum("eg,egp,egq->epq", mesh.wdet, p, p)
    Gd = np.einsum("eg,egp,egai->epai", mesh.wdet, p, mesh.G).reshape(-1, 3, 18)
    Kvol = kappa * np.einsum("epa,epq,eqb->eab", Gd, np.linalg.inv(M), Gd)
    return Kdev + Kvol


# ----------------------------------------------------------------------------- linear contact
class LinearContact:
    """One factorisation of K (symmetry BCs) and the compliance matrix of the candidates."""

    def __init__(self, mesh, nu, element="Q9"):
        self.mesh = mesh
        K = mesh.assemble(linear_stiffness(mesh, nu, element))
        free = np.setdiff1d(np.arange(mesh.ndof), mesh.fixed)
        self.free = free
        self.lu = spla.splu(K[free][:, free].tocsc(), permc_spec="MMD_AT_PLUS_A",
                            diag_pivot_thresh=0.0, options=dict(SymmetricMode=True))
        del K
        pos = np.full(mesh.ndof, -1)
        pos[free] = np.arange(len(free))
        self.cpos = pos[mesh.cand_dof]
        m = len(self.cpos)
        Cm = np.empty((m, m))
        for c0 in range(0, m, 64):                            # Cm = S K^-1 S^T, in chunks
            c1 = min(m, c0 + 64)
            rhs = np.zeros((len(free), c1 - c0))
            rhs[self.cpos[c0:c1], np.arange(c1 - c0)] = 1.0
            Cm[:, c0:c1] = self.lu.solve(rhs)[self.cpos]
        self.Cm = 0.5 * (Cm + Cm.T)
        self.Lc = np.linalg.cholesky(self.Cm)

    def solve(self, delta):
        m = self.mesh
        d = m.cand_Y - (R - 0.5 * delta)                      # overlap if not deformed
        lam_c, _ = nnls(self.Lc.T, np.linalg.solve(self.Lc, d), maxiter=50 * len(d))
        gap = self.Cm @ lam_c - d
        assert gap.min() > -1e-9 * delta, gap.min()
        act = lam_c > 0
        assert not act[-1], "contact reached the last candidate node: raise PSI_CAND"
        rhs = np.zeros(len(self.free))
        rhs[self.cpos] = -lam_c
        u = np.zeros(m.ndof)
        u[self.free] = self.lu.solve(rhs)
        return dict(F=2 * lam_c.sum(), lam=lam_c, u=u, active=act,
                    b=contact_width(m, act))


def contact_width(mesh, act):
    """Half-width estimate: midway between the last node in contact and the next one."""
    k = np.nonzero(act)[0].max()
    return 0.5 * (mesh.cand_x[k] + mesh.cand_x[k + 1])


# ----------------------------------------------------------------------------- finite strain
def nonlinear_contact(mesh, nu, delta, model, u0, act0, tol=1e-10, maxit=40):
    """Newton + primal-dual active set for the hyperelastic disk against the plate."""
    lam, mu = lame(nu)
    u, act = u0.copy(), act0.copy()
    gbound = (R - 0.5 * delta) - mesh.cand_Y                  # u_y <= gbound at candidates
    fref = None
    for it in range(maxit):
        fe, Ke = element_arrays(mesh, u, lam, mu, model)
        fint = mesh.scatter(fe)
        lam_c = -fint[mesh.cand_dof]                          # plate force on the node (down +)
        if fref is None:
            fref = max(np.abs(lam_c).sum(), 1e-12)
        changed = False
        if it > 0:
            new = (act & (lam_c > 0)) | (~act & (u[mesh.cand_dof] > gbound + 1e-12 * R))
            changed = np.any(new != act)
            act = new
        fixed = np.concatenate([mesh.fixed, mesh.cand_dof[act]])
        free = np.setdiff1d(np.arange(mesh.ndof), fixed)
        res = np.linalg.norm(fint[free])
        if it > 0 and not changed and res < tol * fref:
            assert not act[-1], "contact reached the last candidate node: raise PSI_CAND"
            return dict(F=2 * lam_c[act].sum(), u=u, active=act, it=it,
                        b=contact_width(mesh, act))
        du = np.zeros(mesh.ndof)
        du[mesh.cand_dof[act]] = gbound[act] - u[mesh.cand_dof[act]]
        K = mesh.assemble(Ke)
        rhs = -fint[free] - K[free][:, mesh.cand_dof[act]] @ du[mesh.cand_dof[act]]
        du[free] = spla.spsolve(K[free][:, free].tocsc(), rhs, permc_spec="MMD_AT_PLUS_A")
        step = 1.0
        while True:                                           # keep J > 0
            try:
                element_arrays_J_check(mesh, u + step * du)
                break
            except FloatingPointError:
                step *= 0.5
                if step < 1e-6:
                    raise RuntimeError("Newton step cannot keep J > 0")
        u = u + step * du
    raise RuntimeError(f"Newton did not converge (nu={nu}, model={model}, res={res:.2e})")


def element_arrays_J_check(mesh, u):
    ue = u[mesh.edof].reshape(-1, 9, 2)
    Fd = I2 + np.einsum("eai,egaJ->egiJ", ue, mesh.G)
    J = Fd[..., 0, 0] * Fd[..., 1, 1] - Fd[..., 0, 1] * Fd[..., 1, 0]
    if np.any(J <= 0):
        raise FloatingPointError


# ----------------------------------------------------------------------------- sensitivity: stick
def linear_full_stick(mesh, nu, eps_out=EPSS, nstep=250):
    """Side calculation (not the frictionless reference): plates with infinite friction.
    Linear elasticity, loading in nstep increments of eps up to max(eps_out).  A node that
    touches the plate keeps the u_x it had when it touched (no slip), and u_y = plate - Y;
    released if its normal reaction becomes tensile.  Solved on the candidate nodes with the
    compliance matrix of their x and y dofs.  Returns {eps: F}."""
    K = mesh.assemble(linear_stiffness(mesh, nu, "Q9"))
    free = np.setdiff1d(np.arange(mesh.ndof), mesh.fixed)
    lu = spla.splu(K[free][:, free].tocsc(), permc_spec="MMD_AT_PLUS_A",
                   diag_pivot_thresh=0.0, options=dict(SymmetricMode=True))
    pos = np.full(mesh.ndof, -1)
    pos[free] = np.arange(len(free))
    okx = pos[2 * mesh.cand] >= 0                             # the x = 0 node has u_x = 0 already
    nx, m = int(okx.sum()), len(mesh.cand)
    cp = pos[np.concatenate([2 * mesh.cand[okx], 2 * mesh.cand + 1])]
    rhs = np.zeros((len(free), len(cp)))
    rhs[cp, np.arange(len(cp))] = 1.0
    Cm = lu.solve(rhs)[cp]
    Cm = 0.5 * (Cm + Cm.T)
    xi = np.full(m, -1)
    xi[okx] = np.arange(nx)
    act, uxf, out = np.zeros(m, bool), np.zeros(m), {}
    emax = max(eps_out)
    for k in range(1, nstep + 1):
        e = emax * k / nstep
        g = (R - 0.5 * approach(e)) - mesh.cand_Y
        for _ in range(100):
            ia = np.nonzero(act)[0]
            ix = ia[xi[ia] >= 0]
            rows = np.concatenate([nx + ia, xi[ix]]).astype(int)
            r = np.zeros(len(cp))
            if len(rows):
                r[rows] = np.linalg.solve(Cm[np.ix_(rows, rows)], np.concatenate([g[ia], uxf[ix]]))
            uc = Cm @ r
            new = act & (r[nx:] <= 0)
            ent = ~act & (uc[nx:] > g + 1e-14)
            if not ent.any() and np.array_equal(new, act):
                break
            ent_x = ent & okx
            uxf[ent_x] = uc[xi[ent_x]]
            act = new | ent
        assert not act[-1]
        for eo in eps_out:
            if abs(e - eo) < 1e-12:
                out[eo] = -2 * r[nx:].sum()
    return out


# ----------------------------------------------------------------------------- validation
def validate():
    out = []
    # (a) uniform pressure p on the rim: plane-strain Lame, u_r = -p (1+nu)(1-2nu) r / E
    mesh = Mesh(0, b_ref=B_REF)
    nu, p = 0.3, 1.0
    lam, mu = lame(nu)
    E = ESTAR * (1 - nu * nu)
    K = mesh.assemble(linear_stiffness(mesh, nu, "Q9"))
    f = rim_traction(mesh, lambda psi: p * np.ones_like(psi), -1.0)
    u = solve_fixed(mesh, K, f)
    ur = -(1 + nu) * (1 - 2 * nu) * p * R / E
    rim = mesh.rim
    err = np.max(np.abs(np.hypot(*(mesh.X[rim] + u.reshape(-1, 2)[rim]).T) - R - ur)) / abs(ur)
    out.append(f"  (a) uniform rim pressure, nu=0.3, coarse mesh: max |u_r - exact|/|u_r| = {err:.1e}")
    # (b) prescribed Hertz pressure on two opposite arcs of half-width b.  "radial": normal to
    # the undeformed circle (the Michell-series set-up of disk-contact-nu.md); "vertical": the
    # same p(x) per unit horizontal length but acting along the plate normal (t_x = 0), which
    # is the direction a frictionless flat plate actually pushes.
    out.append("  (b) Hertz pressure p(x) = p0 sqrt(1 - x^2/b^2) prescribed on the two arcs, Q2P1, n_b = 20:")
    out.append("      b/R   traction  nu   sx(0)/(F/piR) sy(0)/(-3F/piR)  delta/Michell(C=1/3)  delta/Johnson")
    for bR in (0.03, 0.114):
        b = bR * R
        mesh = Mesh(2, b_ref=b, psi_unif=max(2 * bR, 0.06), depth_unif=max(0.5 * b, 0.02 * R))
        p0 = 2.0 / (np.pi * b)
        prof = lambda psi: p0 * np.sqrt(np.clip(1 - (R * np.sin(psi) / b) ** 2, 0, None))
        for nu in (0.3, 0.49):
            K = mesh.assemble(linear_stiffness(mesh, nu, "Q2P1"))
            for direction in ("radial", "vertical"):
                f = rim_traction(mesh, prof, -1.0, vertical=(direction == "vertical"))
                Ftot = -2 * f[1::2].sum()                     # the quarter carries half of F
                u = solve_fixed(mesh, K, f)
                delta = -2 * u[2 * mesh.rim[0] + 1]
                sx, sy = centre_stress(mesh, u, nu)
                out.append(f"      {bR:5.3f} {direction:8s} {nu:5.2f}  {sx / (Ftot / (np.pi * R)):.4f}"
                           f"        {sy / (-3 * Ftot / (np.pi * R)):.4f}         "
                           f"{delta / michell_delta(Ftot, nu, b=b):.5f}            "
                           f"{delta / johnson_delta(Ftot, b=b):.5f}")
    return out


def rim_traction(mesh, p_of_psi, sign, vertical=False):
    """Consistent nodal forces of a rim pressure p(psi) (sign -1: pushing inwards), normal to
    the circle, or (vertical=True) p per unit horizontal length acting along -y."""
    f = np.zeros(mesh.ndof)
    g, w = np.polynomial.legendre.leggauss(12)
    P = mesh.rim_psi
    for k in range(0, len(P) - 2, 2):
        a, c = P[k], P[k + 2]
        t = g
        psi = 0.5 * (a + c) + 0.5 * (c - a) * t
        Nl = np.stack([0.5 * t * (t - 1), 1 - t * t, 0.5 * t * (t + 1)], -1)
        # exact arc: ds = R dpsi, outward normal (sin psi, cos psi)
        ds = R * 0.5 * (c - a) * w
        pr = p_of_psi(psi)
        for i, node in enumerate(mesh.rim[k:k + 3]):
            if not vertical:
                f[2 * node] += sign * np.sum(Nl[:, i] * pr * np.sin(psi) * ds)
            f[2 * node + 1] += sign * np.sum(Nl[:, i] * pr * np.cos(psi) * ds)
    return f


def solve_fixed(mesh, K, f):
    free = np.setdiff1d(np.arange(mesh.ndof), mesh.fixed)
    u = np.zeros(mesh.ndof)
    u[free] = spla.spsolve(K[free][:, free].tocsc(), f[free], permc_spec="MMD_AT_PLUS_A")
    return u


def centre_stress(mesh, u, nu):
    """sigma_x, sigma_y at the Gauss point nearest the centre (small-strain)."""
    lam, mu = lame(nu)
    ue = u[mesh.edof].reshape(-1, 9, 2)
    H = np.einsum("eai,egaJ->egiJ", ue, mesh.G)
    eps = 0.5 * (H + np.swapaxes(H, -1, -2))
    tr = eps[..., 0, 0] + eps[..., 1, 1]
    sig = lam * tr[..., None, None] * I2 + 2 * mu * eps
    r = np.hypot(mesh.xg[..., 0], mesh.xg[..., 1])
    e, g = np.unravel_index(np.argmin(r), r.shape)
    return sig[e, g, 0, 0], sig[e, g, 1, 1]


# ----------------------------------------------------------------------------- studies
def richardson(f1, f2, f3):
    """Observed order from three nested meshes and the extrapolated value from the two finest;
    (nan, finest) when the differences are not monotone (contact-edge quantisation noise)."""
    d1, d2 = f1 - f2, f2 - f3
    if d1 * d2 <= 0 or abs(d1) <= abs(d2):
        return np.nan, f3
    p = np.log2(d1 / d2)
    return p, f3 - d2 / (2 ** p - 1)


def window_means():
    """Neo-Hookean F(nu)/F(0.45) averaged over the window the MPM example averages
    (`examples/mpm_convergence.rs`, column J(mean)): mean over eps = 0.010 ... 0.050 of
    F_nh / F_lin(0.45), level-1 mesh (its ratios agree with level 3 to 1e-4), 9 strains."""
    mesh = Mesh(1)
    eps = np.linspace(0.01, 0.05, 9)
    nus = (0.0, 0.2, 0.3, 0.45, 0.49)
    print("   eps    " + "  ".join(f"F({nu:.2f})/F(0.45)" for nu in nus))
    ratio = {nu: [] for nu in nus}
    for e in eps:
        lin = {nu: LinearContact(mesh, nu, "Q9").solve(approach(e)) for nu in nus}
        nh = {nu: nonlinear_contact(mesh, nu, approach(e), "nh", lin[nu]["u"], lin[nu]["active"])["F"]
              for nu in nus}
        for nu in nus:
            ratio[nu].append(nh[nu] / lin[0.45]["F"])
        print(f"   {e:5.3f}  " + "  ".join(f"{nh[nu] / nh[0.45]:16.5f}" for nu in nus), flush=True)
    mean = {nu: np.mean(ratio[nu]) for nu in nus}
    print("   window " + "  ".join(f"{mean[nu] / mean[0.45]:16.5f}" for nu in nus))


def main():
    if "--window" in sys.argv:
        window_means()
        return
    fine = "--fine" in sys.argv
    t0 = time.time()
    print(f"R = {R} mm, E* = {ESTAR:.4f} MPa fixed, E = E*(1-nu^2); forces in N/m per unit thickness")
    FJ = {e: force_from(johnson_delta, e) for e in EPSS}
    FM = {(e, nu): force_from(lambda F: michell_delta(F, nu), e) for e in EPSS for nu in NUS}
    FM2 = {(e, nu): force_from(lambda F: michell_delta(F, nu, 16 / (9 * np.pi)), e)
           for e in EPSS for nu in NUS}
    print(f"Johnson (A): F = {1e3 * FJ[0.02]:.2f} at eps=0.02, {1e3 * FJ[0.05]:.2f} at eps=0.05")

    print("\n== Validation")
    for line in validate():
        print(line)
    print(f"   [{time.time() - t0:.0f} s]")

    levels = [1, 2, 3] + ([4] if fine else [])
    meshes = {}
    print("\n== Linear elasticity, exact frictionless contact: mesh convergence")
    print("   level n_b  elements   dofs   element  nu   F(0.02)[N/m]  b/R     F(0.05)[N/m]  b/R")
    lin = {}
    for L in levels:
        mesh = Mesh(L)
        if L <= 2:
            meshes[L] = mesh
        for el in ("Q9", "Q2P1"):
            for nu in NUS:
                if el == "Q2P1" and L == 4:                   # Q9 = Q2P1 to 1e-5 on level 3
                    continue
                lc = LinearContact(mesh, nu, el)
                rs = [lc.solve(approach(e)) for e in EPSS]
                for e, r in zip(EPSS, rs):
                    if L > 2:
                        r.pop("u")
                    lin[(L, el, nu, e)] = r
                print(f"   {L:5d} {mesh.n_b:3d} {len(mesh.el):9d} {mesh.ndof:7d}  {el:5s} {nu:5.2f}"
                      f"  {1e3 * rs[0]['F']:11.3f}  {rs[0]['b'] / R:.4f}  {1e3 * rs[1]['F']:11.3f}"
                      f"  {rs[1]['b'] / R:.4f}", flush=True)
                del lc
        del mesh
    print(f"   [{time.time() - t0:.0f} s]")

    print("\n== Linear: Richardson over the three finest levels (order nan = differences not monotone:")
    print("   the contact edge moves between nodes; then the finest value is kept), and comparisons")
    print("   element nu    eps   F by level (coarse -> fine)            order  F_best    "
          "F/Johnson  F/Michell(1/3)  F/Michell(0.566)")
    best = {}
    for el in ("Q9", "Q2P1"):
        for nu in NUS:
            for e in EPSS:
                fs = [1e3 * lin[(L, el, nu, e)]["F"] for L in levels if (L, el, nu, e) in lin]
                p, fx = richardson(*fs[-3:])
                best[(el, nu, e)] = fx
                print(f"   {el:5s} {nu:5.2f} {e:5.2f}  " + " ".join(f"{f:9.3f}" for f in fs)
                      + " " * (10 * (4 - len(fs))) + f"  {p:5.2f}  {fx:9.3f}  {fx / (1e3 * FJ[e]):.5f}"
                      f"    {fx / (1e3 * FM[(e, nu)]):.5f}        {fx / (1e3 * FM2[(e, nu)]):.5f}")

    print("\n== Linear: F(nu)/F(0.45) at fixed E*, per mesh and best")
    for e in EPSS:
        print(f"   eps = {e}")
        print("   element level  " + "  ".join(f"nu={nu:.2f}" for nu in NUS))
        for el in ("Q9", "Q2P1"):
            for L in levels:
                if (L, el, 0.45, e) not in lin:
                    continue
                f45 = lin[(L, el, 0.45, e)]["F"]
                print(f"   {el:5s} {L:5d}   " + "  ".join(
                    f"{lin[(L, el, nu, e)]['F'] / f45:.5f}" if (L, el, nu, e) in lin else "   -   "
                    for nu in NUS))
            print(f"   {el:5s} best    " + "  ".join(
                f"{best[(el, nu, e)] / best[(el, 0.45, e)]:.5f}" for nu in NUS))
        print("   Michell C=1/3    " + "  ".join(f"{FM[(e, nu)] / FM[(e, 0.45)]:.5f}" for nu in NUS))
        print("   Michell C=0.566  " + "  ".join(f"{FM2[(e, nu)] / FM2[(e, 0.45)]:.5f}" for nu in NUS))
    print(f"   [{time.time() - t0:.0f} s]")

    print("\n== Finite strain (total Lagrangian, Q9 displacement, Newton + active set)")
    print("   model level nu    eps   F_lin[N/m]  F_nl[N/m]  F_nl/F_lin  b/R(nl)  newton_its")
    nl = {}
    summary = {}
    for L in (1, 2):
        mesh = meshes[L]
        for model in ("nh", "svk"):
            for nu in NUS:
                for e in EPSS:
                    r0 = lin[(L, "Q9", nu, e)]
                    r = nonlinear_contact(mesh, nu, approach(e), model, r0["u"], r0["active"])
                    nl[(model, L, nu, e)] = r
                    print(f"   {model:4s} {L:5d} {nu:5.2f} {e:5.2f}  {1e3 * r0['F']:10.3f}  "
                          f"{1e3 * r['F']:9.3f}  {r['F'] / r0['F']:.5f}    {r['b'] / R:.4f}   {r['it']:3d}",
                          flush=True)
    print(f"   [{time.time() - t0:.0f} s]")

    print("\n== Finite strain: F(nu)/F(0.45) per mesh, and best estimate "
          "F = F_lin,best(Q2P1) * (F_nl/F_lin)_level2")
    for e in EPSS:
        print(f"   eps = {e}")
        print("   model level  " + "  ".join(f"nu={nu:.2f}" for nu in NUS)
              + "   F(0.45)[N/m]  F(0.45)/Johnson")
        for model in ("nh", "svk"):
            for L in (1, 2):
                f45 = nl[(model, L, 0.45, e)]["F"]
                print(f"   {model:4s} {L:5d}  " + "  ".join(
                    f"{nl[(model, L, nu, e)]['F'] / f45:.5f}" for nu in NUS)
                    + f"   {1e3 * f45:10.3f}")
            fb = {nu: best[("Q2P1", nu, e)] * nl[(model, 2, nu, e)]["F"] / lin[(2, "Q9", nu, e)]["F"]
                  for nu in NUS}
            print(f"   {model:4s} best   " + "  ".join(f"{fb[nu] / fb[0.45]:.5f}" for nu in NUS)
                  + f"   {fb[0.45]:10.3f}    {fb[0.45] / (1e3 * FJ[e]):.4f}")
            summary[(model, e)] = fb

    if fine:
        print("\n== (--fine) neo-Hookean on level 3 (n_b = 40), nu = 0.30 and 0.45")
        mesh = Mesh(3)
        f3 = {}
        for nu in (0.30, 0.45):
            lc = LinearContact(mesh, nu, "Q9")
            for e in EPSS:
                r0 = lc.solve(approach(e))
                r = nonlinear_contact(mesh, nu, approach(e), "nh", r0["u"], r0["active"])
                f3[(nu, e)] = r["F"]
                print(f"   nu = {nu:.2f}  eps = {e}:  F_nh = {1e3 * r['F']:.3f}  F_nh/F_lin = "
                      f"{r['F'] / r0['F']:.5f}  (level 2: {nl[('nh', 2, nu, e)]['F'] / lin[(2, 'Q9', nu, e)]['F']:.5f})")
            del lc
        for e in EPSS:
            print(f"   eps = {e}: F_nh(0.30)/F_nh(0.45) = {f3[(0.30, e)] / f3[(0.45, e)]:.5f} (level 2: "
                  f"{nl[('nh', 2, 0.30, e)]['F'] / nl[('nh', 2, 0.45, e)]['F']:.5f})")
        del mesh

    print("\n== Neo-Hookean: nu effect against strain.  Level-1 mesh (n_b = 10) scaled to Johnson's b")
    print("   at each strain (at eps = 0.02 level 1 and 2 ratios agree to 5e-5).  Linear: none at all.")
    print("   eps     b/R    F_nh(0.30)/F_nh(0.45)  F_nh(0.49)/F_nh(0.45)  F_nh(0.45)/F_lin  F_nh(0.45)/Johnson")
    for e in (0.002, 0.005, 0.01, 0.02, 0.03, 0.05):
        FJe = force_from(johnson_delta, e)
        bJ = np.sqrt(4 * FJe * R / (np.pi * ESTAR))
        mesh = Mesh(1, b_ref=bJ, psi_unif=2.3 * bJ / R, depth_unif=0.53 * bJ)
        F = {}
        for nu in (0.30, 0.45, 0.49):
            r0 = LinearContact(mesh, nu, "Q9").solve(approach(e))
            F[nu] = nonlinear_contact(mesh, nu, approach(e), "nh", r0["u"], r0["active"])["F"]
            if nu == 0.45:
                flin, bR = r0["F"], r0["b"] / R
        print(f"   {e:5.3f}  {bR:.3f}       {F[0.30] / F[0.45]:.5f}                {F[0.49] / F[0.45]:.5f}"
              f"              {F[0.45] / flin:.5f}          {F[0.45] / FJe:.5f}")
    print("\n== Side calculation: plates with full stick (infinite friction), linear, Q9, level 1")
    print("   (the MPM's plates are frictionless; this only bounds what a tangential traction can do)")
    st = {nu: linear_full_stick(meshes[1], nu) for nu in NUS}
    for e in EPSS:
        print(f"   eps = {e}: F = " + "  ".join(f"{1e3 * st[nu][e]:.2f}" for nu in NUS)
              + "   F(nu)/F(0.45) = " + "  ".join(f"{st[nu][e] / st[0.45][e]:.4f}" for nu in NUS))

    print("\n== SUMMARY: best F [N/m] per nu (linear: finest Q2P1; finite strain: linear x (F_nl/F_lin) on")
    print("   level 2), F(nu)/F(0.45), and F/Johnson.  Johnson (A) is nu-free at fixed E*.")
    print("   model   eps    " + "  ".join(f"F({nu:.2f})" for nu in NUS) + "   |  "
          + "  ".join(f"r({nu:.2f})" for nu in NUS) + "  |  " + "  ".join(f"J({nu:.2f})" for nu in NUS))
    for e in EPSS:
        summary[("linear", e)] = {nu: best[("Q2P1", nu, e)] for nu in NUS}
        for model in ("linear", "nh", "svk"):
            fb = summary[(model, e)]
            print(f"   {model:6s} {e:5.2f}  " + "  ".join(f"{fb[nu]:7.2f}" for nu in NUS) + "   |  "
                  + "  ".join(f"{fb[nu] / fb[0.45]:.4f}" for nu in NUS) + "  |  "
                  + "  ".join(f"{fb[nu] / (1e3 * FJ[e]):.4f}" for nu in NUS))
    print(f"\n   total {time.time() - t0:.0f} s")


if __name__ == "__main__":
    main()
