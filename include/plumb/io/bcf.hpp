// SPDX-License-Identifier: BSD-3-Clause
#pragma once

/// @file
/// @brief BCF 2.1 (BIM Collaboration Format, buildingSMART) writer: issues about building elements
///        ("topics"), each with a camera viewpoint and the elements it is about, as a .bcf zip
///        archive that BIM viewers open.
///
/// Archive layout (ZIP, entries stored uncompressed):
/// ```
/// bcf.version              <Version VersionId="2.1">
/// project.bcfp             <ProjectExtension> with the project's id and name
/// GUID/markup.bcf          per topic: <Markup> with the <Topic> and its <Viewpoints>
/// GUID/viewpoint.bcfv      per topic: <VisualizationInfo> with the components and the camera
/// ```
/// Each XML file follows the schema of its kind (version.xsd, project.xsd, markup.xsd, visinfo.xsd).

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "plumb/core/types.hpp"

namespace plumb::io {

/// @brief One building element a viewpoint is about.
struct BcfComponent {
  std::string ifc_guid;  ///< the element's IFC GlobalId: 22 characters of 0-9 A-Z a-z _ $
  std::string color;     ///< "RRGGBB" or "RRGGBBAA" in upper-case hex; empty = not coloured
};

/// @brief A perspective camera in the model's world frame (IFC coordinates, metres).
struct BcfCamera {
  Vector3d viewpoint = Vector3d::Zero();   ///< camera position [m]
  Vector3d direction = Vector3d::UnitX();  ///< viewing direction (not zero)
  Vector3d up = Vector3d::UnitZ();         ///< up vector (not zero, not along `direction`)
  double field_of_view_deg = 60.0;         ///< vertical field of view, in [45, 60] degrees (BCF 2.1)
};

/// @brief One issue: a title, a description, who raised it and when, and one viewpoint.
struct BcfTopic {
  std::string guid;         ///< UUID "xxxxxxxx-xxxx-xxxx-xxxx-xxxxxxxxxxxx"; empty = bcf_guid(seed, title and index)
  std::string title;        ///< required, not empty
  std::string description;  ///< may be empty
  std::string author;       ///< CreationAuthor, required (e.g. an e-mail address)
  std::string date;         ///< CreationDate, xs:dateTime given by the caller, e.g. "2026-03-01T12:00:00Z"
  std::string type;         ///< TopicType, e.g. "Issue"; empty = none
  std::string status;       ///< TopicStatus, e.g. "Open"; empty = none
  BcfCamera camera;                     ///< the viewpoint's camera
  std::vector<BcfComponent> components;  ///< selected (and, with a colour, coloured) elements
};

/// @brief A BCF project: a name and its topics.
struct BcfProject {
  std::string name;        ///< project name (may be empty)
  std::string project_id;  ///< empty = bcf_guid(seed, "project" and name)
  std::uint64_t seed = 1;  ///< the GUIDs left empty are derived from it and the content
  std::vector<BcfTopic> topics;
};

/// @brief A deterministic UUID (RFC 9562 version 8, lower-case hex) from a seed and a text: the
///        same arguments give the same UUID, different ones (in practice) different UUIDs.
std::string bcf_guid(std::uint64_t seed, std::string_view content);

/// @brief True when `s` has the form of an IFC GlobalId (22 characters of 0-9 A-Z a-z _ $), the form
///        BcfComponent::ifc_guid must have.
bool is_ifc_guid(std::string_view s);

/// @brief Write `project` as a BCF 2.1 archive at `path` (usually *.bcf). The archive is written to
///        a temporary file beside `path` and renamed onto it once complete, so that a failure
///        leaves no partial file and an existing file is replaced only by a complete archive.
/// @throws plumb::Error naming `path` when it cannot be written, and naming the topic and field on
///         bad content: an empty title or author, a date that is not an xs:dateTime, a GUID that is
///         not a UUID, a component's IfcGuid or colour of the wrong form, a non-finite or zero camera
///         vector, a field of view outside [45, 60] degrees, two topics with one GUID, or text with
///         control characters XML cannot hold.
void write_bcf(const std::string& path, const BcfProject& project);

}  // namespace plumb::io
