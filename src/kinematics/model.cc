#include "rmpmarl/kinematics/model.h"

#include <fmt/format.h>

#include <cmath>

#include "rmpmarl/common/error.h"

namespace rmpmarl::kinematics {

std::string_view JointTypeName(JointType type) {
  switch (type) {
    case JointType::kFixed: return "fixed";
    case JointType::kRevolute: return "revolute";
    case JointType::kContinuous: return "continuous";
    case JointType::kPrismatic: return "prismatic";
  }
  return "unknown";
}

Model::Model(std::string name, std::vector<Link> links, std::vector<DofLimits> limits)
    : name_(std::move(name)), links_(std::move(links)), limits_(std::move(limits)) {
  if (links_.empty()) throw InputError(fmt::format("robot '{}': expected at least one link, got none", name_));
  if (links_[0].parent != -1 || links_[0].q_index != -1) {
    throw InputError(fmt::format("robot '{}': link 0 ('{}') must be the root", name_, links_[0].name));
  }
  const int n_links = num_links();
  const int n_q = nq();
  dof_link_.assign(n_q, -1);
  for (int k = 1; k < n_links; ++k) {
    const Link& link = links_[k];
    if (link.parent < 0 || link.parent >= k) {
      throw InputError(fmt::format("robot '{}': link '{}' has parent index {}, expected one in [0, {}) "
                                   "(links in topological order)", name_, link.name, link.parent, k));
    }
    const bool moving = link.joint_type != JointType::kFixed;
    const bool mimic = link.mimic_dof >= 0;
    if (moving != (link.q_index >= 0 || mimic) || (mimic && link.q_index >= 0)) {
      throw InputError(fmt::format("robot '{}': joint '{}' of type {} has q_index {} and mimic dof {}", name_,
                                   link.joint_name, JointTypeName(link.joint_type), link.q_index, link.mimic_dof));
    }
    if (mimic) {
      if (link.mimic_dof >= n_q || !std::isfinite(link.mimic_multiplier) || !std::isfinite(link.mimic_offset)) {
        throw InputError(fmt::format("robot '{}': mimic joint '{}' expected a dof in [0, {}) and a finite "
                                     "multiplier and offset, got dof {}, multiplier {}, offset {}", name_,
                                     link.joint_name, n_q, link.mimic_dof, link.mimic_multiplier, link.mimic_offset));
      }
      has_mimic_ = true;
    }
    if (moving && std::abs(link.axis_J.norm() - 1.0) > 1e-9) {
      throw InputError(fmt::format("robot '{}': joint '{}' axis must be a unit vector, got norm {}", name_,
                                   link.joint_name, link.axis_J.norm()));
    }
    if (link.q_index >= 0) {
      if (link.q_index >= n_q || dof_link_[link.q_index] != -1) {
        throw InputError(fmt::format("robot '{}': joint '{}' has q_index {}, expected a unique index in [0, {})",
                                     name_, link.joint_name, link.q_index, n_q));
      }
      dof_link_[link.q_index] = k;
    }
  }
  for (int i = 0; i < n_q; ++i) {
    if (dof_link_[i] < 0) throw InputError(fmt::format("robot '{}': no joint has q_index {}", name_, i));
    const DofLimits& l = limits_[i];
    if (!(l.lower <= l.upper) || !(l.velocity > 0.0) || std::isnan(l.effort)) {
      throw InputError(fmt::format("robot '{}': joint '{}' limits: expected lower <= upper and velocity > 0, "
                                   "got lower={} upper={} velocity={}", name_, dof_name(i), l.lower, l.upper,
                                   l.velocity));
    }
  }
  supports_.assign(static_cast<size_t>(n_links) * n_q, 0);
  ancestor_.assign(static_cast<size_t>(n_links) * n_links, 0);
  link_dofs_.assign(n_links, {});
  dof_joint_links_.assign(n_q, {});
  for (int i = 0; i < n_q; ++i) dof_joint_links_[i].push_back(dof_link_[i]);
  ancestor_[0] = 1;
  for (int k = 1; k < n_links; ++k) {
    const Link& link = links_[k];
    for (int i = 0; i < n_q; ++i) supports_[k * n_q + i] = supports_[link.parent * n_q + i];
    for (int a = 0; a < n_links; ++a) ancestor_[static_cast<size_t>(k) * n_links + a] =
        ancestor_[static_cast<size_t>(link.parent) * n_links + a];
    ancestor_[static_cast<size_t>(k) * n_links + k] = 1;
    const int dof = link.driving_dof();
    if (dof >= 0) supports_[k * n_q + dof] = 1;
    if (link.mimic_dof >= 0) dof_joint_links_[link.mimic_dof].push_back(k);
  }
  for (int k = 0; k < n_links; ++k) {
    for (int i = 0; i < n_q; ++i) {
      if (supports_[k * n_q + i]) link_dofs_[k].push_back(i);
    }
  }
}

int Model::FindLink(std::string_view name) const {
  for (int k = 0; k < num_links(); ++k) {
    if (links_[k].name == name) return k;
  }
  return -1;
}

int Model::LinkIndex(std::string_view name) const {
  const int k = FindLink(name);
  if (k >= 0) return k;
  std::string known;
  for (const Link& link : links_) known += (known.empty() ? "" : ", ") + link.name;
  throw InputError(fmt::format("robot '{}': no link named '{}' (links: {})", name_, name, known));
}

Eigen::VectorXd Model::LowerLimits() const {
  Eigen::VectorXd v(nq());
  for (int i = 0; i < nq(); ++i) v[i] = limits_[i].lower;
  return v;
}

Eigen::VectorXd Model::UpperLimits() const {
  Eigen::VectorXd v(nq());
  for (int i = 0; i < nq(); ++i) v[i] = limits_[i].upper;
  return v;
}

Eigen::VectorXd Model::VelocityLimits() const {
  Eigen::VectorXd v(nq());
  for (int i = 0; i < nq(); ++i) v[i] = limits_[i].velocity;
  return v;
}

Data::Data(const Model& model)
    : X_WL(model.num_links(), Eigen::Isometry3d::Identity()),
      axis_W(Eigen::Matrix3Xd::Zero(3, model.nq())),
      axis_WL(Eigen::Matrix3Xd::Zero(3, model.num_links())),
      w_WL(Eigen::Matrix3Xd::Zero(3, model.num_links())),
      v_WLo(Eigen::Matrix3Xd::Zero(3, model.num_links())),
      alpha_bias_WL(Eigen::Matrix3Xd::Zero(3, model.num_links())),
      a_bias_WLo(Eigen::Matrix3Xd::Zero(3, model.num_links())) {}

}  // namespace rmpmarl::kinematics
