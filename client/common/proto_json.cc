#include "client/common/proto_json.h"

#include <google/protobuf/descriptor.h>

#include <algorithm>
#include <cctype>

namespace waymark::cli {
namespace {

using google::protobuf::EnumValueDescriptor;
using google::protobuf::FieldDescriptor;
using google::protobuf::Message;
using google::protobuf::Reflection;

std::string Lowercase(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return text;
}

// RECOGNITION_MODE_PAPER -> "paper": the value name without its type-name prefix, by the proto
// style rule that enum values are prefixed with the enum's name in UPPER_SNAKE_CASE.
std::string EnumName(const EnumValueDescriptor* value) {
  std::string prefix;
  for (char c : value->type()->name()) {
    if (std::isupper(static_cast<unsigned char>(c)) && !prefix.empty()) prefix += '_';
    prefix += static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  }
  prefix += '_';
  std::string name = value->name();
  if (name.rfind(prefix, 0) == 0) name = name.substr(prefix.size());
  return Lowercase(name);
}

nlohmann::json FieldValue(const Message& message, const Reflection* reflection,
                          const FieldDescriptor* field, int index) {
  const bool repeated = index >= 0;
  switch (field->cpp_type()) {
    case FieldDescriptor::CPPTYPE_INT32:
      return repeated ? reflection->GetRepeatedInt32(message, field, index)
                      : reflection->GetInt32(message, field);
    case FieldDescriptor::CPPTYPE_INT64:
      return repeated ? reflection->GetRepeatedInt64(message, field, index)
                      : reflection->GetInt64(message, field);
    case FieldDescriptor::CPPTYPE_UINT32:
      return repeated ? reflection->GetRepeatedUInt32(message, field, index)
                      : reflection->GetUInt32(message, field);
    case FieldDescriptor::CPPTYPE_UINT64:
      return repeated ? reflection->GetRepeatedUInt64(message, field, index)
                      : reflection->GetUInt64(message, field);
    case FieldDescriptor::CPPTYPE_DOUBLE:
      return repeated ? reflection->GetRepeatedDouble(message, field, index)
                      : reflection->GetDouble(message, field);
    case FieldDescriptor::CPPTYPE_FLOAT:
      return repeated ? reflection->GetRepeatedFloat(message, field, index)
                      : reflection->GetFloat(message, field);
    case FieldDescriptor::CPPTYPE_BOOL:
      return repeated ? reflection->GetRepeatedBool(message, field, index)
                      : reflection->GetBool(message, field);
    case FieldDescriptor::CPPTYPE_ENUM:
      return EnumName(repeated ? reflection->GetRepeatedEnum(message, field, index)
                               : reflection->GetEnum(message, field));
    case FieldDescriptor::CPPTYPE_STRING:
      if (field->type() == FieldDescriptor::TYPE_BYTES) {
        // Image bytes are useless on a terminal; their size is what a reader wants to know.
        const std::string bytes = repeated ? reflection->GetRepeatedString(message, field, index)
                                           : reflection->GetString(message, field);
        return nlohmann::json{{"bytes", bytes.size()}};
      }
      return repeated ? reflection->GetRepeatedString(message, field, index)
                      : reflection->GetString(message, field);
    case FieldDescriptor::CPPTYPE_MESSAGE:
      return ProtoToJson(repeated ? reflection->GetRepeatedMessage(message, field, index)
                                  : reflection->GetMessage(message, field));
  }
  return nullptr;
}

}  // namespace

nlohmann::json ProtoToJson(const Message& message) {
  nlohmann::json json = nlohmann::json::object();
  const Reflection* reflection = message.GetReflection();
  const auto* descriptor = message.GetDescriptor();
  for (int i = 0; i < descriptor->field_count(); ++i) {
    const FieldDescriptor* field = descriptor->field(i);
    if (field->is_repeated()) {
      nlohmann::json values = nlohmann::json::array();
      for (int j = 0; j < reflection->FieldSize(message, field); ++j) {
        values.push_back(FieldValue(message, reflection, field, j));
      }
      json[field->name()] = std::move(values);
    } else if (!field->has_presence() || reflection->HasField(message, field)) {
      json[field->name()] = FieldValue(message, reflection, field, -1);
    }
  }
  return json;
}

std::string ModeName(v1::RecognitionMode mode) {
  const EnumValueDescriptor* value = v1::RecognitionMode_descriptor()->FindValueByNumber(mode);
  return value != nullptr ? EnumName(value) : std::to_string(static_cast<int>(mode));
}

}  // namespace waymark::cli
