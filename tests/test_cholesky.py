"""The sparse Cholesky of the 3D tooth-sector stiffness (hacgear_core.statics.cholesky): the same solutions as a
sparse LU to round-off, one triangle stored, a fill-reducing order."""
import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from hacgear_core.errors import SolverError
from hacgear_core.statics.cholesky import SparseCholesky, nested_dissection


@pytest.fixture(scope="module")
def elastic_block():
    """Free-free P2 elasticity stiffness of a 3D block held on its bottom face, and its free DOF locations [m]."""
    from skfem import Basis, ElementTetP2, ElementVector, MeshTet, asm
    from skfem.models.elasticity import lame_parameters, linear_elasticity

    mesh = MeshTet.init_tensor(np.linspace(0, 0.04, 7), np.linspace(0, 0.02, 4), np.linspace(0, 0.03, 5))
    basis = Basis(mesh, ElementVector(ElementTetP2()))
    K = asm(linear_elasticity(*lame_parameters(206e9, 0.3)), basis).tocsr()
    free = np.flatnonzero(basis.doflocs[2] > 1e-9)
    return K[free][:, free].tocsc(), basis.doflocs[:, free].T


def test_cholesky_solves_like_lu(elastic_block):
    K, X = elastic_block
    before = K.copy()
    perm = nested_dissection(K.tocsr(), X, leaf=16)
    assert (K != before).nnz == 0                                     # the input is left as it is
    Kr = K.tocsr()
    nested_dissection(Kr, X, leaf=16)
    assert (Kr != before).nnz == 0 and Kr.nnz == before.nnz
    assert np.array_equal(np.sort(perm), np.arange(K.shape[0]))
    ch = SparseCholesky(K, perm)
    B = np.random.default_rng(3).standard_normal((K.shape[0], 5))
    ref = spla.splu(K, permc_spec="COLAMD").solve(B)
    U = ch.solve(B)
    assert np.abs(U - ref).max() <= 1e-10 * np.abs(ref).max()      # round-off (measured 1e-14)
    np.testing.assert_allclose(ch.solve(B[:, 2]), U[:, 2], rtol=0, atol=1e-14 * np.abs(U).max())
    # the natural order gives the same solution too
    U0 = SparseCholesky(K).solve(B)
    assert np.abs(U0 - ref).max() <= 1e-10 * np.abs(ref).max()


def test_nested_dissection_stores_less_than_lu(elastic_block):
    """One triangle in a nested-dissection order: fewer stored entries than the natural-order Cholesky and than
    the two triangles of SuperLU's LU (COLAMD), the memory the 3D sector model saves."""
    K, X = elastic_block
    ch = SparseCholesky(K, nested_dissection(K, X, leaf=16))
    lu = spla.splu(K, permc_spec="COLAMD")
    assert ch.nnz < SparseCholesky(K).nnz
    assert ch.nnz < 0.75 * (lu.L.nnz + lu.U.nnz)


def test_cholesky_refuses_an_indefinite_matrix():
    A = sp.csc_matrix(np.array([[1.0, 2.0], [2.0, 1.0]]))
    with pytest.raises(SolverError, match="not positive definite"):
        SparseCholesky(A)


def test_tooth_sector_model_solves_like_lu():
    """The 3D tooth-sector model (fe3d.ToothSectorFE, factorised by SparseCholesky) gives the displacements of a
    sparse LU of its own stiffness, zero on the held rim cut."""
    from skfem import asm
    from skfem.models.elasticity import lame_parameters, linear_elasticity

    from hacgear_core.geometry import gear_geometry
    from hacgear_core.kinds import load_model
    from hacgear_core.statics import fe3d

    wheel = {g.name: g for g in load_model("helical_28_33").gears}["wheel"]
    gg = gear_geometry(wheel)
    mat = fe3d.material_of(wheel)
    fe = fe3d.ToothSectorFE(gg, mat, fe3d.Mesh3DOptions().scaled(2.5))      # coarse: a few thousand DOF
    K = asm(linear_elasticity(*lame_parameters(mat.youngs_modulus_Pa, mat.poisson_ratio)), fe.basis).tocsr()
    Kff = K[fe.free][:, fe.free].tocsc()
    F = np.random.default_rng(7).standard_normal((fe.n_dofs, 3))
    U = fe.solve(F)
    ref = spla.splu(Kff, permc_spec="COLAMD").solve(F[fe.free])
    assert np.abs(U[fe.free] - ref).max() <= 1e-10 * np.abs(ref).max()       # round-off (measured ~1e-14)
    fixed = np.setdiff1d(np.arange(fe.n_dofs), fe.free)
    assert fixed.size > 0 and np.all(U[fixed] == 0.0)
