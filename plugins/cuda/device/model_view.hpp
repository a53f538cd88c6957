// The robot constants as the fused kernel reads them: flat arrays in one block of S and one block
// of int, uploaded once per instance (model_upload.hpp builds them). A view is a few pointers,
// passed to the kernel by value.
#pragma once

#include "spatial.hpp"

namespace rbdgrad::cuda {

template <class S>
struct ModelView {
  int nv = 0;
  const int* parent = nullptr;        // (nv) parent joint, -1 for the world; parent[i] < i
  const int* subtree_end = nullptr;   // (nv) one past the last joint of joint i's subtree
  const int* prismatic = nullptr;     // (nv) 1 prismatic along z, 0 revolute about z
  // (nv) the root of joint i's tree: the roots' subtrees do not couple, so M, M^-1 and the
  // inverse-dynamics derivatives are block diagonal over them (a fixed-base humanoid's legs and
  // torso); row i's block is [root_of[i], subtree_end[root_of[i]])
  const int* root_of = nullptr;
  // the joints level by level from the roots (depth 1), in index order within a level:
  // level L is level_joints[level_start[L] .. level_start[L + 1]); the block kernel's passes that
  // are serial over the tree (articulated-body) go a level at a time
  const int* level_joints = nullptr;  // (nv)
  const int* level_start = nullptr;   // (levels + 1)
  int levels = 0;                     // the tree's depth
  // M, M^-1 and the inverse-dynamics derivatives packed by the roots' blocks (the compact block
  // kernel, block_fused_state.hpp): entry (i, j), j in row i's block, at matrix_row[i] + j, the
  // blocks' square matrices one after the other, matrix_scalars in all (talos_reduced's blocks of
  // 6, 6 and 20 joints: 472 where the dense matrix takes 1,024; a tree with one root packs nothing)
  const int* matrix_row = nullptr;    // (nv)
  int matrix_scalars = 0;
  const S* joint_rotation = nullptr;  // (9 nv) joint frame in the parent body frame, row-major
  const S* joint_translation = nullptr;  // (3 nv)
  const S* mass = nullptr;            // (nv)
  const S* com = nullptr;             // (3 nv) body frame
  const S* inertia_com = nullptr;     // (9 nv) about the centre of mass, row-major
  const S* link_rotation = nullptr;   // (9 nv) URDF link frame to body frame, row-major
  S gravity[3] = {S(0), S(0), S(0)};  // world frame

  // i ancestor-or-self of j, in depth-first order
  RBDGRAD_HD bool contains(int i, int j) const { return i <= j && j < subtree_end[i]; }
  // (i, j) can be nonzero in M, L and the inverse-dynamics derivatives: one is an ancestor of the other
  RBDGRAD_HD bool related(int i, int j) const { return contains(i, j) || contains(j, i); }

  RBDGRAD_HD Mat3<S> mat3(const S* base, int i) const {
    Mat3<S> out;
    for (int k = 0; k < 9; ++k) out.m[k] = base[9 * i + k];
    return out;
  }
};

// A ModelView whose sizes are compile-time constants: the block kernel compiled for one robot when
// its model is loaded (kernel_source.cpp) sees nv and the tree's depth as constants, so that its
// loops over joints have fixed trip counts and its index arithmetic divides by constants; the
// lean build sees the packed matrices' size too (MATRIX_SCALARS, 0: the view's, at run time), so
// that its working set's arrays all sit at constant offsets (ptxas: no spills at 72 registers for
// talos_reduced, where the run-time size spills 8 bytes). The arrays are the same as the view's.
// Code that takes a ModelView<S>& sees the run-time sizes, which are equal.
template <class S, int NV, int LEVELS, int MATRIX_SCALARS = 0>
struct FixedSizeModelView : ModelView<S> {
  static_assert(NV >= 1 && LEVELS >= 1 && LEVELS <= NV, "a tree of NV joints is 1 to NV levels deep");
  static_assert(MATRIX_SCALARS >= 0 && MATRIX_SCALARS <= NV * NV, "the packed matrices are at most nv x nv");
  static constexpr int nv = NV;
  static constexpr int levels = LEVELS;
  static constexpr int matrix_scalars = MATRIX_SCALARS;
  RBDGRAD_HD explicit FixedSizeModelView(const ModelView<S>& view) : ModelView<S>(view) {}
};

// A FixedSizeModelView whose tree is a constant too (the warp kernel compiled for one robot): each
// joint's parent and subtree end packed in 4 bits (parent + 1 and end - 1, up to 16 joints), so
// that a lane has its joint's without a load from device memory, which the first shuffles waited
// for (ncu, run 68: 6% of the kernel's stall samples at 65536 states).
template <class S, int NV, int LEVELS, unsigned long long PARENTS, unsigned long long SUBTREE_ENDS>
struct FixedTreeModelView;

// FixedTreeModelView's packing: value + bias in 4 bits a joint (parents: bias 1, subtree ends:
// bias -1), written by the host for the generated source and read by the kernel.
RBDGRAD_HD constexpr unsigned long long pack_tree_nibbles(const int* values, int nv, int bias) {
  unsigned long long packed = 0;
  for (int i = 0; i < nv; ++i) packed |= static_cast<unsigned long long>(values[i] + bias) << (4 * i);
  return packed;
}
RBDGRAD_HD constexpr int unpack_tree_nibble(unsigned long long packed, int i, int bias) {
  return static_cast<int>(packed >> (4 * i) & 15u) - bias;
}
inline constexpr int kParentBias = 1, kSubtreeEndBias = -1;

template <class S, int NV, int LEVELS, unsigned long long PARENTS, unsigned long long SUBTREE_ENDS>
struct FixedTreeModelView : FixedSizeModelView<S, NV, LEVELS> {
  static_assert(NV <= 16, "4 bits a joint");
  RBDGRAD_HD explicit FixedTreeModelView(const ModelView<S>& view) : FixedSizeModelView<S, NV, LEVELS>(view) {}
};

// A FixedSizeModelView whose tree is a constant too (the block kernel's lean build compiled for one
// robot): Tree, written into the kernel's source at model load (kernel_source.cpp), gives each
// joint's parent and subtree end by constexpr functions parent(i) and subtree_end(i), so that a
// pass unrolled over the joints finds its indices as constants (block_tree_sums.hpp).
template <class S, int NV, int LEVELS, int MATRIX_SCALARS, class Tree>
struct TreeModelView : FixedSizeModelView<S, NV, LEVELS, MATRIX_SCALARS> {
  RBDGRAD_HD explicit TreeModelView(const ModelView<S>& view)
      : FixedSizeModelView<S, NV, LEVELS, MATRIX_SCALARS>(view) {}
};

// The number of joints, the tree depth and the packed matrices' size a model type fixes at compile
// time, 0 for run-time sizes.
template <class Model>
struct FixedSizes {
  static constexpr int nv = 0, levels = 0, matrix_scalars = 0;
};
template <class S, int NV, int LEVELS, int MATRIX_SCALARS>
struct FixedSizes<FixedSizeModelView<S, NV, LEVELS, MATRIX_SCALARS>> {
  static constexpr int nv = NV, levels = LEVELS, matrix_scalars = MATRIX_SCALARS;
};
template <class S, int NV, int LEVELS, unsigned long long P, unsigned long long E>
struct FixedSizes<FixedTreeModelView<S, NV, LEVELS, P, E>> : FixedSizes<FixedSizeModelView<S, NV, LEVELS>> {};
template <class S, int NV, int LEVELS, int MATRIX_SCALARS, class Tree>
struct FixedSizes<TreeModelView<S, NV, LEVELS, MATRIX_SCALARS, Tree>>
    : FixedSizes<FixedSizeModelView<S, NV, LEVELS, MATRIX_SCALARS>> {};

// A joint's parent and subtree end from the model type where it fixes the tree, else (known:
// false) from the view's arrays.
template <class Model>
struct FixedTree {
  static constexpr bool known = false;
  static RBDGRAD_HD int parent(const Model& m, int i) { return m.parent[i]; }
  static RBDGRAD_HD int subtree_end(const Model& m, int i) { return m.subtree_end[i]; }
};
template <class S, int NV, int LEVELS, unsigned long long P, unsigned long long E>
struct FixedTree<FixedTreeModelView<S, NV, LEVELS, P, E>> {
  using Model = FixedTreeModelView<S, NV, LEVELS, P, E>;
  static constexpr bool known = true;
  static RBDGRAD_HD constexpr int parent(const Model&, int i) { return unpack_tree_nibble(P, i, kParentBias); }
  static RBDGRAD_HD constexpr int subtree_end(const Model&, int i) { return unpack_tree_nibble(E, i, kSubtreeEndBias); }
};
template <class S, int NV, int LEVELS, int MATRIX_SCALARS, class Tree>
struct FixedTree<TreeModelView<S, NV, LEVELS, MATRIX_SCALARS, Tree>> {
  using Model = TreeModelView<S, NV, LEVELS, MATRIX_SCALARS, Tree>;
  static constexpr bool known = true;
  static RBDGRAD_HD constexpr int parent(const Model&, int i) { return Tree::parent(i); }
  static RBDGRAD_HD constexpr int subtree_end(const Model&, int i) { return Tree::subtree_end(i); }
};

// A joint's parent as a constant expression, without a view (known: the model type's tree is
// constexpr): what a table built at compile time from the tree needs (block_tree_chains.hpp); and
// whether M^-1 goes by the tree's chains, and its columns then by the tree's blocks
// (block_tree_columns.hpp) (the kernel compiled for a robot: as its build says; the host tests'
// views: where they fit).
template <class Model>
struct TreeConstants {
  static constexpr bool known = false;
  static constexpr bool chains = true;
  static constexpr bool columns = true;
};
template <class S, int NV, int LEVELS, int MATRIX_SCALARS, class Tree>
struct TreeConstants<TreeModelView<S, NV, LEVELS, MATRIX_SCALARS, Tree>> {
  static constexpr bool known = true;
  static constexpr bool chains = Tree::chains;
  static constexpr bool columns = Tree::columns;
  static RBDGRAD_HD constexpr int parent(int i) { return Tree::parent(i); }
};

// Where each array starts, in scalars of the S block and ints of the int block.
struct ModelLayout {
  static constexpr int kScalarsPerJoint = 9 + 3 + 1 + 3 + 9 + 9;
  static constexpr int kIntsPerJoint = 7;
  static RBDGRAD_HD int scalars(int nv) { return kScalarsPerJoint * nv; }
  // level_start has at most nv + 1 entries
  static RBDGRAD_HD int ints(int nv) { return kIntsPerJoint * nv + 1; }
  static RBDGRAD_HD int matrix_row(int nv) { return 6 * nv + 1; }
};

// A view onto blocks laid out as ModelLayout says (host or device memory alike).
template <class S>
RBDGRAD_HD ModelView<S> model_view(int nv, int levels, int matrix_scalars, const S* scalars, const int* ints,
                                   const S (&gravity)[3]) {
  ModelView<S> m;
  m.nv = nv;
  m.parent = ints;
  m.subtree_end = ints + nv;
  m.prismatic = ints + 2 * nv;
  m.root_of = ints + 3 * nv;
  m.level_joints = ints + 4 * nv;
  m.level_start = ints + 5 * nv;
  m.levels = levels;
  m.matrix_row = ints + ModelLayout::matrix_row(nv);
  m.matrix_scalars = matrix_scalars;
  m.joint_rotation = scalars;
  m.joint_translation = m.joint_rotation + 9 * nv;
  m.mass = m.joint_translation + 3 * nv;
  m.com = m.mass + nv;
  m.inertia_com = m.com + 3 * nv;
  m.link_rotation = m.inertia_com + 9 * nv;
  for (int r = 0; r < 3; ++r) m.gravity[r] = gravity[r];
  return m;
}

}  // namespace rbdgrad::cuda
