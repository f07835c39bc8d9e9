// Python classes for aerovo's options structs, generated from their option schema
// (core/options.h: `VisitFields(Struct&, V&)`), so that every field of the schema is a Python
// attribute with its doc, type and range checks and no field list is copied here.
//
// BindOptions<T>(module, "Name") makes class aerovo.Name with:
// - one property per v.Field(member, key, doc, spec): the value as bool / int / float / str
//   (an enum as its name, e.g. "clustered"); setting it checks the Python type (TypeError) and
//   the schema's range (ValueError "SurfOptions.hessian_threshold must be >= 0, got -1");
// - one property per v.Group(name, child): the nested options object (a live view: setting
//   o.ransac.seed changes o), assignable from an object of the child's class or a dict;
// - __init__(**kwargs) (any attribute, e.g. SurfOptions(hessian_threshold=500, upright=True);
//   an unknown name is a TypeError listing the valid ones), to_dict() (nested dicts),
//   __repr__, __eq__, and fields(): the schema's rows (key, type, default, range, doc).
// The child classes of groups must be bound before the parent.
// Not a hot path: every attribute access walks the struct's field list.
#pragma once

#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <climits>
#include <cstdint>
#include <string>
#include <type_traits>
#include <vector>

#include "aerovo/core/options.h"

namespace aerovo::python {

namespace py = pybind11;

/// The attribute names of an options class (fields, groups, hand-bound extras), in schema order.
template <class T>
std::vector<std::string>& AttributeNames() {
  static std::vector<std::string> names;
  return names;
}

inline std::string PyTypeName(py::handle h) {
  return py::str(py::type::handle_of(h).attr("__name__")).cast<std::string>();
}

/// The Python value of a field: bool, int, float, str (an enum as its name).
template <class T>
py::object FieldToPython(const T& v) {
  if constexpr (std::is_enum_v<T>) {
    return py::str(options::EnumName(v));
  } else {
    return py::cast(v);
  }
}

/// A field's new value from Python; `what` = "SurfOptions.hessian_threshold" for messages.
/// bool fields take a bool only, integer fields an int (not a bool, not a float), floating
/// fields an int or a float, enum fields one of their names; numbers must be in the range.
template <class T>
T FieldFromPython(py::handle h, const std::string& what, const options::Spec& spec) {
  if constexpr (std::is_same_v<T, bool>) {
    if (!py::isinstance<py::bool_>(h)) {
      throw py::type_error(what + " must be a bool, got " + PyTypeName(h));
    }
    return h.cast<bool>();
  } else if constexpr (std::is_enum_v<T>) {
    if (!py::isinstance<py::str>(h)) {
      throw py::type_error(what + " must be a str, one of " + options::EnumChoices<T>() +
                           ", got " + PyTypeName(h));
    }
    const std::string name = h.cast<std::string>();
    const auto e = options::ParseEnum<T>(name);
    if (!e) {
      throw py::value_error(what + " must be one of " + options::EnumChoices<T>() + ", got '" +
                            name + "'");
    }
    return *e;
  } else if constexpr (std::is_same_v<T, std::string>) {
    if (!py::isinstance<py::str>(h)) {
      throw py::type_error(what + " must be a str, got " + PyTypeName(h));
    }
    return h.cast<std::string>();
  } else if constexpr (std::is_integral_v<T>) {
    if (py::isinstance<py::bool_>(h) || !py::isinstance<py::int_>(h)) {
      throw py::type_error(what + " must be an int, got " + PyTypeName(h));
    }
    T value{};
    if constexpr (std::is_unsigned_v<T>) {
      const unsigned long long u = PyLong_AsUnsignedLongLong(h.ptr());
      if (PyErr_Occurred()) {
        PyErr_Clear();
        throw py::value_error(what + " must be in [0, 2^64), got " + py::str(h).cast<std::string>());
      }
      value = static_cast<T>(u);
    } else {
      int overflow = 0;
      const long long s = PyLong_AsLongLongAndOverflow(h.ptr(), &overflow);
      if (overflow != 0 || s < static_cast<long long>(std::numeric_limits<T>::min()) ||
          s > static_cast<long long>(std::numeric_limits<T>::max())) {
        throw py::value_error(what + " does not fit in a " + options::TypeName<T>() + ", got " +
                              py::str(h).cast<std::string>());
      }
      value = static_cast<T>(s);
    }
    if (spec.HasRange() && !spec.Contains(static_cast<double>(value))) {
      throw py::value_error(what + " must be " + spec.Describe() + ", got " +
                            options::FormatNumber(value));
    }
    return value;
  } else {
    static_assert(std::is_floating_point_v<T>, "option field of an unsupported type");
    if (py::isinstance<py::bool_>(h) || !(py::isinstance<py::float_>(h) || py::isinstance<py::int_>(h))) {
      throw py::type_error(what + " must be a float, got " + PyTypeName(h));
    }
    const T value = static_cast<T>(h.cast<double>());
    if (spec.HasRange() && !spec.Contains(static_cast<double>(value))) {
      throw py::value_error(what + " must be " + spec.Describe() + ", got " +
                            options::FormatNumber(value));
    }
    return value;
  }
}

/// Visitor that calls f(member, spec) for the field named `name` of the visited struct only.
template <class F>
struct OneField {
  const std::string& name;
  F f;
  template <class T>
  void Field(T& member, const char* key, const char*, const options::Spec& spec) {
    if (name == key) f(member, spec);
  }
  template <class T>
  void Group(const char*, T&) {}
};
template <class F>
OneField(const std::string&, F) -> OneField<F>;

/// Visitor that calls f(child) for the group named `name` of the visited struct only.
template <class F>
struct OneGroup {
  const std::string& name;
  F f;
  template <class T>
  void Field(T&, const char*, const char*, const options::Spec&) {}
  template <class T>
  void Group(const char* group, T& child) {
    if (name == group) f(child);
  }
};
template <class F>
OneGroup(const std::string&, F) -> OneGroup<F>;

/// Sets the attributes of the Python object `obj` from `values` (kwargs or a dict), checking
/// the names first (TypeError naming the valid ones).
template <class T>
void SetAttributes(py::handle obj, py::handle values, const std::string& class_name) {
  const std::vector<std::string>& names = AttributeNames<T>();
  for (const auto item : py::reinterpret_borrow<py::dict>(values)) {
    const std::string key = py::str(item.first).cast<std::string>();
    if (std::find(names.begin(), names.end(), key) == names.end()) {
      std::string valid;
      for (const std::string& n : names) valid += (valid.empty() ? "" : ", ") + n;
      throw py::type_error(class_name + " has no option '" + key + "' (options: " + valid + ")");
    }
    py::setattr(obj, item.first, item.second);
  }
}

/// A T from an optional T (None: T{}) and keyword overrides: what every function taking
/// options (options=None, **kwargs) uses.
template <class T>
T MakeOptions(const py::object& options, const py::kwargs& kwargs, const char* class_name) {
  T base{};
  if (!options.is_none()) {
    if (!py::isinstance<T>(options)) {
      throw py::type_error(std::string("options must be an aerovo.") + class_name + " or None, got " +
                           PyTypeName(options));
    }
    base = options.cast<T>();
  }
  if (kwargs.empty()) return base;
  py::object tmp = py::cast(base);
  SetAttributes<T>(tmp, kwargs, class_name);
  return tmp.cast<T>();
}

/// The class's to_dict(): every attribute, nested options as dicts.
inline py::dict ToDict(py::handle obj, const std::vector<std::string>& names) {
  py::dict out;
  for (const std::string& n : names) {
    py::object v = obj.attr(n.c_str());
    out[n.c_str()] = py::hasattr(v, "to_dict") ? v.attr("to_dict")() : v;
  }
  return out;
}

template <class T>
class OptionsBinder {
 public:
  OptionsBinder(py::class_<T>& cls, std::string class_name)
      : cls_(cls), class_name_(std::move(class_name)) {}

  template <class M>
  void Field(M&, const char* key, const char* doc, const options::Spec& spec) {
    const std::string name = key;
    const std::string what = class_name_ + "." + name;
    std::string full_doc = std::string(doc) + " (";
    if constexpr (std::is_enum_v<M>) {
      full_doc += "str: " + options::EnumChoices<M>();
    } else {
      full_doc += PythonTypeName<M>();
    }
    if (spec.HasRange()) full_doc += ", " + spec.Describe();
    full_doc += ")";
    cls_.def_property(
        key,
        [name](T& self) {
          py::object out;
          OneField v{name, [&](auto& m, const options::Spec&) { out = FieldToPython(m); }};
          VisitFields(self, v);
          return out;
        },
        [name, what](T& self, py::handle value) {
          OneField v{name, [&](auto& m, const options::Spec& s) {
                       m = FieldFromPython<std::decay_t<decltype(m)>>(value, what, s);
                     }};
          VisitFields(self, v);
        },
        full_doc.c_str());
    AttributeNames<T>().push_back(name);
  }

  template <class C>
  void Group(const char* group, C&) {
    const std::string name = group;
    const std::string what = class_name_ + "." + name;
    cls_.def_property(
        group,
        [name](py::object self_obj) {
          T& self = self_obj.cast<T&>();
          py::object out;
          OneGroup v{name, [&](auto& child) {
                       out = py::cast(&child, py::return_value_policy::reference_internal,
                                      self_obj);
                     }};
          VisitFields(self, v);
          return out;
        },
        [name, what](py::object self_obj, py::handle value) {
          T& self = self_obj.cast<T&>();
          OneGroup v{name, [&](auto& child) {
                       using Child = std::decay_t<decltype(child)>;
                       if (py::isinstance<Child>(value)) {
                         child = value.cast<Child>();
                       } else if (py::isinstance<py::dict>(value)) {
                         py::object tmp = py::cast(child);
                         SetAttributes<Child>(tmp, value, what);
                         child = tmp.cast<Child>();
                       } else {
                         throw py::type_error(what + " must be an options object or a dict, got " +
                                              PyTypeName(value));
                       }
                     }};
          VisitFields(self, v);
        },
        ("Nested options (" + name + ".*)").c_str());
    AttributeNames<T>().push_back(name);
  }

 private:
  template <class M>
  static const char* PythonTypeName() {
    if constexpr (std::is_same_v<M, bool>) return "bool";
    else if constexpr (std::is_integral_v<M>) return "int";
    else if constexpr (std::is_floating_point_v<M>) return "float";
    else return "str";
  }

  py::class_<T>& cls_;
  std::string class_name_;
};

/// Binds T as aerovo.<name> (see the header comment). Returns the class for extras (fields that
/// are not in the schema, e.g. OdometryOptions::focal_px): add them with AddExtra.
template <class T>
py::class_<T> BindOptions(py::module_& m, const char* name, const char* doc) {
  py::class_<T> cls(m, name, doc);
  const std::string class_name = name;
  cls.def(py::init([class_name](py::kwargs kwargs) {
            if (kwargs.empty()) return T{};
            py::object tmp = py::cast(T{});
            SetAttributes<T>(tmp, kwargs, class_name);
            return tmp.cast<T>();
          }),
          "Default options, then every keyword argument set as an attribute.");
  T proto{};
  OptionsBinder<T> binder(cls, class_name);
  VisitFields(proto, binder);
  cls.def("to_dict", [](py::object self) { return ToDict(self, AttributeNames<T>()); },
          "Every option as a dict (nested options as nested dicts).");
  cls.def("__repr__", [class_name](py::object self) {
    std::string out = class_name + "(";
    bool first = true;
    for (const std::string& n : AttributeNames<T>()) {
      out += (first ? "" : ", ") + n + "=" + py::repr(self.attr(n.c_str())).cast<std::string>();
      first = false;
    }
    return out + ")";
  });
  cls.def("__eq__", [](py::object a, py::object b) {
    if (!py::isinstance<T>(b)) return false;
    return a.attr("to_dict")().equal(b.attr("to_dict")());
  });
  cls.def("__copy__", [](const T& self) { return T(self); });
  cls.def("__deepcopy__", [](const T& self, py::dict) { return T(self); });
  cls.def_static(
      "fields",
      []() {
        py::list out;
        for (const options::FieldInfo& f : options::ListFields(T{})) {
          py::dict row;
          row["key"] = f.key;
          row["type"] = f.type;
          row["default"] = f.value;
          row["range"] = f.range;
          row["doc"] = f.doc;
          out.append(row);
        }
        return out;
      },
      "The option schema's rows of this struct, nested groups included: dicts with key "
      "(\"ransac.seed\"), type, default (as text), range and doc.");
  return cls;
}

/// Records a hand-bound attribute (not in the schema) so that __init__, to_dict and __repr__
/// know it.
template <class T>
void AddExtraName(const char* name) {
  AttributeNames<T>().push_back(name);
}

}  // namespace aerovo::python
