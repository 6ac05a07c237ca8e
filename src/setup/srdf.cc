// MoveIt's SRDF → setup::Srdf, through TinyXML (the XML parser urdfdom itself is built on); see srdf.h.
#include "rmpmarl/setup/srdf.h"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <tinyxml.h>

#include <algorithm>
#include <fstream>
#include <sstream>

#include "rmpmarl/common/error.h"

namespace rmpmarl::setup {

using namespace kinematics;  // the robot description being set up: kinematics' types throughout
namespace {

// the attribute's value, "" when absent.
std::string Attribute(const TiXmlElement& e, const char* name) {
  const char* value = e.Attribute(name);
  return value != nullptr ? std::string(value) : std::string();
}

// the attribute's value; throws InputError naming the source, line, element and attribute when it is absent or empty.
std::string Required(const TiXmlElement& e, const char* name, const std::string& source) {
  std::string value = Attribute(e, name);
  if (value.empty()) {
    throw InputError(fmt::format("{}:{}: <{}>: expected a non-empty attribute {}=\"...\", got none", source, e.Row(),
                                 e.Value(), name));
  }
  return value;
}

SrdfGroup ParseGroup(const TiXmlElement& e, const std::string& source) {
  SrdfGroup group;
  group.name = Required(e, "name", source);
  group.line = e.Row();
  for (const TiXmlElement* c = e.FirstChildElement(); c != nullptr; c = c->NextSiblingElement()) {
    const std::string tag = c->Value();
    if (tag == "chain") {
      group.chains.push_back({Required(*c, "base_link", source), Required(*c, "tip_link", source)});
    } else if (tag == "link") {
      group.links.push_back(Required(*c, "name", source));
    } else if (tag == "joint") {
      group.joints.push_back(Required(*c, "name", source));
    } else if (tag == "group") {
      group.subgroups.push_back(Required(*c, "name", source));
    }
  }
  return group;
}

// "a, b, c" of the model's link names.
std::string LinkNames(const Model& model) {
  std::string names;
  for (int k = 0; k < model.num_links(); ++k) names += (k ? ", " : "") + model.link(k).name;
  return names;
}

bool HasJoint(const Model& model, const Srdf& srdf, const std::string& name) {
  for (int k = 1; k < model.num_links(); ++k) {
    if (model.link(k).joint_name == name) return true;
  }
  return std::any_of(srdf.virtual_joints.begin(), srdf.virtual_joints.end(),
                     [&](const SrdfVirtualJoint& v) { return v.name == name; });
}

}  // namespace

Srdf ParseSrdf(const std::string& xml, const std::string& source) {
  TiXmlDocument doc;
  doc.Parse(xml.c_str());
  if (doc.Error()) {
    throw InputError(fmt::format("{}: not valid XML (line {}, column {}: {})", source, doc.ErrorRow(), doc.ErrorCol(),
                                 doc.ErrorDesc()));
  }
  const TiXmlElement* root = doc.RootElement();
  if (root == nullptr || std::string(root->Value()) != "robot") {
    throw InputError(fmt::format("{}: not an SRDF: expected the root element <robot>, got {}", source,
                                 root == nullptr ? std::string("no element") : fmt::format("<{}>", root->Value())));
  }
  Srdf srdf;
  srdf.source = source;
  srdf.robot_name = Attribute(*root, "name");
  for (const TiXmlElement* e = root->FirstChildElement(); e != nullptr; e = e->NextSiblingElement()) {
    const std::string tag = e->Value();
    if (tag == "disable_collisions") {
      srdf.disabled_collisions.push_back(
          {Required(*e, "link1", source), Required(*e, "link2", source), Attribute(*e, "reason"), e->Row()});
    } else if (tag == "end_effector") {
      srdf.end_effectors.push_back({Required(*e, "name", source), Required(*e, "parent_link", source),
                                    Attribute(*e, "group"), Attribute(*e, "parent_group"), e->Row()});
    } else if (tag == "virtual_joint") {
      srdf.virtual_joints.push_back({Required(*e, "name", source), Attribute(*e, "type"),
                                     Attribute(*e, "parent_frame"), Required(*e, "child_link", source), e->Row()});
    } else if (tag == "group") {
      srdf.groups.push_back(ParseGroup(*e, source));
    }
  }
  return srdf;
}

Srdf LoadSrdf(const std::filesystem::path& path) {
  std::ifstream file(path);
  if (!file) throw InputError(fmt::format("{}: cannot open SRDF file (missing or unreadable)", path.string()));
  std::stringstream buffer;
  buffer << file.rdbuf();
  return ParseSrdf(buffer.str(), path.string());
}

std::vector<std::string> CheckSrdfAgainstModel(const Srdf& srdf, const Model& model) {
  auto unknown_link = [&](int line, const std::string& element, const std::string& attribute,
                          const std::string& link) {
    return InputError(fmt::format("{}:{}: <{}> {}: expected one of the URDF's links ({}), got '{}' (an SRDF of "
                                  "another robot? pass the right one, or none)", srdf.source, line, element,
                                  attribute, LinkNames(model), link));
  };
  for (const SrdfEndEffector& ee : srdf.end_effectors) {
    if (model.FindLink(ee.parent_link) < 0) {
      throw unknown_link(ee.line, fmt::format("end_effector name=\"{}\"", ee.name), "parent_link", ee.parent_link);
    }
  }
  for (const SrdfVirtualJoint& v : srdf.virtual_joints) {
    if (model.FindLink(v.child_link) < 0) {
      throw unknown_link(v.line, fmt::format("virtual_joint name=\"{}\"", v.name), "child_link", v.child_link);
    }
  }

  std::vector<std::string> warnings;
  if (!srdf.robot_name.empty() && srdf.robot_name != model.name()) {
    warnings.push_back(fmt::format("{}: <robot name=\"{}\">: expected the URDF's robot name '{}'", srdf.source,
                                   srdf.robot_name, model.name()));
  }
  for (const SrdfDisabledPair& p : srdf.disabled_collisions) {
    for (const std::string& link : {p.link1, p.link2}) {
      if (model.FindLink(link) >= 0) continue;
      warnings.push_back(fmt::format("{}:{}: <disable_collisions link1=\"{}\" link2=\"{}\">: no link '{}' in the "
                                     "URDF: pair skipped", srdf.source, p.line, p.link1, p.link2, link));
      break;
    }
  }
  for (const SrdfGroup& g : srdf.groups) {
    std::vector<std::string> unknown;
    for (const SrdfChain& c : g.chains) {
      for (const std::string& link : {c.base_link, c.tip_link}) {
        if (model.FindLink(link) < 0) unknown.push_back(fmt::format("link '{}'", link));
      }
    }
    for (const std::string& link : g.links) {
      if (model.FindLink(link) < 0) unknown.push_back(fmt::format("link '{}'", link));
    }
    for (const std::string& joint : g.joints) {
      if (!HasJoint(model, srdf, joint)) unknown.push_back(fmt::format("joint '{}'", joint));
    }
    if (!unknown.empty()) {
      warnings.push_back(fmt::format("{}:{}: <group name=\"{}\">: not in the URDF: {}", srdf.source, g.line, g.name,
                                     fmt::join(unknown, ", ")));
    }
  }
  return warnings;
}

}  // namespace rmpmarl::setup
