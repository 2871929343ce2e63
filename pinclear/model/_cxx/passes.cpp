// pinclear's per-evaluation Pinocchio passes as one C function that compiled code can call.
//
// Why: the compiled step logic (pinclear/stepping) runs every stage of an evaluation inside
// numba; only Pinocchio's tree algorithms live outside it. numba calls
// pinclear_passes through its address, with the addresses of the pin.Model / pin.Data objects
// the Python side owns (model_address / data_address below), so Pinocchio still computes M, b,
// J and dJ, on the very Data whose arrays the kernels already read.
//
// Without bits 4 and 8 the passes give, bit for bit, what pinclear.kinematics.update's sequence
// of library calls gives (tests/model/test_native_build.py compares every array they write):
//   computeJointJacobiansTimeVariation(model, data, q, v)   oMi, J, dJ, v
//   updateFramePlacements(model, data)        (flags & 1)   oMf (force elements read frames)
//   crba(model, data, q, LOCAL)               (flags & 2)   M (upper triangle)
//   nonLinearEffects(model, data, q, v)                     nle
// but in one forward sweep over the joints instead of three: each joint's step of the Jacobian
// pass (Pinocchio's own, impl::JointJacobiansTimeVariationForwardStep), then the lines of crba's
// and NLE's forward steps that follow their own jmodel.calc, liMi = jointPlacements * jdata.M()
// and (NLE) v[i] = jdata.v() + liMi.actInv(v[parent]): the Jacobian step has just computed these
// same expressions from the same q and v into the same Data fields (jacobian.hxx,
// crba.hxx CrbaLocalConventionForwardStep, rnea.hxx NLEForwardStep). The backward sweeps, crba's
// mimic step and armature are Pinocchio's own. The frame placements read oMi alone, so they
// come last. Each joint's sines and cosines are computed once instead of three times: the
// passes cost 0.6-0.8x the three library calls (benchmarks/bench_reproduce_runs.md).
// The position level (flags & 4: the Gauss-Newton iterations of the projections onto the
// constraint manifold, which need placements and Jacobians at each iterate, no velocities):
//   computeJointJacobians(model, data, q)                   oMi, J
//   updateFramePlacements / crba as above     (flags & 1, 2; crba's forward step reduced to
//                                                            Ycrb[i] = I_i the same way)
// The mass matrix alone (flags & 8: the velocity projection at a q whose positions are done):
//   crba(model, data, q, LOCAL)                             M (upper triangle)
#include <Python.h>

#include <pinocchio/multibody.hpp>
#include <pinocchio/algorithm/jacobian.hpp>
#include <pinocchio/algorithm/frames.hpp>
#include <pinocchio/algorithm/crba.hpp>
#include <pinocchio/algorithm/rnea.hpp>

#include <boost/python.hpp>
#include <boost/fusion/include/vector.hpp>

#include <cstdint>

namespace bp = boost::python;
using Model = pinocchio::Model;
using Data = pinocchio::Data;
using VecMap = Eigen::Map<const Eigen::VectorXd>;

namespace {

// One forward sweep for the three passes: each joint's step of computeJointJacobiansTimeVariation
// (Pinocchio's own, impl::JointJacobiansTimeVariationForwardStep: calc, liMi, oMi, v, J, ov, dJ),
// then crba's Ycrb[i] = I_i and the lines of impl::NLEForwardStep after its calc / liMi / v, which
// the Jacobian step has just written from the same q and v: NLE's bias acceleration (gravity
// through a_gf[0]) and force.
struct PassesForward : pinocchio::fusion::JointUnaryVisitorBase<PassesForward>
{
  typedef boost::fusion::vector<const Model &, Data &, const VecMap &, const VecMap &, const bool &> ArgsType;

  template<typename JointModel>
  static void algo(const pinocchio::JointModelBase<JointModel> & jmodel,
                   pinocchio::JointDataBase<typename JointModel::JointDataDerived> & jdata, const Model & model,
                   Data & data, const VecMap & q, const VecMap & v, const bool & mass)
  {
    pinocchio::impl::JointJacobiansTimeVariationForwardStep<double, 0, pinocchio::JointCollectionDefaultTpl, VecMap,
                                                            VecMap>::algo(jmodel, jdata, model, data, q, v);
    const Model::JointIndex i = jmodel.id();
    const Model::JointIndex parent = model.parents[i];
    if (mass)
      data.Ycrb[i] = model.inertias[i];
    data.a_gf[i] = jdata.c() + (data.v[i] ^ jdata.v());
    data.a_gf[i] += data.liMi[i].actInv(data.a_gf[parent]);
    data.f[i] = model.inertias[i] * data.a_gf[i] + model.inertias[i].vxiv(data.v[i]);  // -f_ext
  }
};

// crba's backward sweep, mimic step and armature (crbaLocalConvention after its forward sweep)
void mass_backward(const Model & model, Data & data)
{
  typedef pinocchio::impl::CrbaLocalConventionBackwardStep<double, 0, pinocchio::JointCollectionDefaultTpl> Pass2;
  for (Model::JointIndex i = (Model::JointIndex)(model.njoints - 1); i > 0; --i)
    Pass2::run(model.joints[i], data.joints[i], Pass2::ArgsType(model, data));
  typedef pinocchio::impl::CrbaLocalConventionMimicStep<double, 0, pinocchio::JointCollectionDefaultTpl> Pass3;
  for (size_t i = 0; i < model.mimicking_joints.size(); i++)
    Pass3::run(model.joints[model.mimicking_joints[i]], data.joints[model.mimicking_joints[i]],
               Pass3::ArgsType(model, data, i));
  data.M.diagonal() += model.armature;
}

// computeJointJacobiansTimeVariation, crba (LOCAL, with ``mass``) and nonLinearEffects at (q, v):
// the library functions' own initialisations around the fused forward sweep, then crba's and
// NLE's backward sweeps as Pinocchio runs them
void passes(const Model & model, Data & data, const VecMap & q, const VecMap & v, bool mass)
{
  data.nle.setZero();
  data.v[0].setZero();
  data.a_gf[0] = -model.gravity;
  for (Model::JointIndex i = 1; i < (Model::JointIndex)model.njoints; ++i)
    PassesForward::run(model.joints[i], data.joints[i], PassesForward::ArgsType(model, data, q, v, mass));
  if (mass)
    mass_backward(model, data);
  typedef pinocchio::impl::NLEBackwardStep<double, 0, pinocchio::JointCollectionDefaultTpl> Pass2;
  for (Model::JointIndex i = (Model::JointIndex)(model.njoints - 1); i > 0; --i)
    Pass2::run(model.joints[i], data.joints[i], Pass2::ArgsType(model, data));
}

}  // namespace

extern "C" __attribute__((visibility("default"))) void pinclear_passes(std::int64_t model_addr, std::int64_t data_addr,
                                                                       std::int64_t q_addr, std::int64_t v_addr,
                                                                       std::int64_t flags)
{
  const Model & model = *reinterpret_cast<const Model *>(model_addr);
  Data & data = *reinterpret_cast<Data *>(data_addr);
  VecMap q(reinterpret_cast<const double *>(q_addr), model.nq);
  VecMap v(reinterpret_cast<const double *>(v_addr), model.nv);
  if (flags & 8) {
    pinocchio::crba(model, data, q, pinocchio::Convention::LOCAL);
    return;
  }
  if (flags & 4) {
    pinocchio::computeJointJacobians(model, data, q);
    if (flags & 1)
      pinocchio::updateFramePlacements(model, data);
    if (flags & 2) {
      // crba's forward step after its calc and liMi, which computeJointJacobians has just done
      for (Model::JointIndex i = 1; i < (Model::JointIndex)model.njoints; ++i)
        data.Ycrb[i] = model.inertias[i];
      mass_backward(model, data);
    }
    return;
  }
  passes(model, data, q, v, flags & 2);
  if (flags & 1)
    pinocchio::updateFramePlacements(model, data);
}

namespace {

std::int64_t model_address(bp::object o)
{
  return reinterpret_cast<std::int64_t>(&bp::extract<const Model &>(o)());
}

std::int64_t data_address(bp::object o)
{
  return reinterpret_cast<std::int64_t>(&bp::extract<Data &>(o)());
}

std::int64_t passes_address()
{
  return reinterpret_cast<std::int64_t>(&pinclear_passes);
}

}  // namespace

BOOST_PYTHON_MODULE(_passes)
{
  bp::import("pinocchio");  // pin.Model / pin.Data converters registered before any extract
  bp::def("model_address", &model_address, "Address of the C++ Model a pin.Model wraps.");
  bp::def("data_address", &data_address, "Address of the C++ Data a pin.Data wraps.");
  bp::def("passes_address", &passes_address, "Address of the C function pinclear_passes.");
  bp::scope().attr("PINOCCHIO_VERSION") = PINOCCHIO_VERSION;
}
