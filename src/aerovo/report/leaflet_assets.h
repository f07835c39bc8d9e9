// Leaflet (Debian's libjs-leaflet; BSD-2-Clause, (c) 2010-2019 Vladimir Agafonkin, (c) 2010-2011
// CloudMade) compiled into the report library, so that report.html inlines it and opens with the
// network off, and an installed aerovo needs no file of it at run time. The bytes are Debian's
// /usr/share/javascript/leaflet/ files as found when CMake configured the build
// (report/CMakeLists.txt generates leaflet_assets.cc from them).
#pragma once

#include <string>
#include <string_view>

namespace aerovo::leaflet {

/// leaflet.min.js, as shipped (no licence header: LicenceComment() holds it).
std::string_view Js();
/// leaflet.css, as shipped: it names its images as url(images/NAME.png).
std::string_view Css();
/// The bytes of images/`name` (layers.png, layers-2x.png, marker-icon.png); empty when unknown.
std::string_view Image(std::string_view name);
/// The licence notice of Leaflet (BSD-2-Clause) as a JavaScript block comment, kept in the
/// inlined text.
std::string LicenceComment();

}  // namespace aerovo::leaflet
