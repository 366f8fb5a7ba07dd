// PLY header model and a value-by-value reader shared by the particle and mesh readers.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "io/io_common.hpp"

namespace trilevel::io {

struct PlyProperty {
    std::string name;
    Scalar type = Scalar::F32;
    std::optional<Scalar> list_count;  ///< set for `property list <count> <type> name`
};

struct PlyElement {
    std::string name;
    std::uint64_t count = 0;
    std::vector<PlyProperty> props;
    bool has_list() const {
        for (const auto& p : props) if (p.list_count) return true;
        return false;
    }
};

struct PlyHeader {
    enum Format { Ascii, BinaryLE, BinaryBE } format = Ascii;
    std::vector<PlyElement> elements;
    std::size_t body = 0;          ///< offset of the first data byte
    std::size_t header_lines = 0;  ///< lines up to and including end_header
};

PlyHeader parse_ply_header(const std::string& path, const std::string& data);

/// Reads the body value by value, ascii or binary alike (slow path: meshes in tests and tools).
class PlyValueReader {
public:
    PlyValueReader(const std::string& path, const std::string& data, const PlyHeader& h);
    double next(Scalar t);
    std::uint64_t list_length(Scalar t);
    void skip(const PlyProperty& p);
    std::string where() const;  ///< "line N" or "offset N" for messages
    std::size_t left() const;   ///< bytes not read yet

private:
    const std::string& path_;
    const std::string& data_;
    bool ascii_, big_;
    std::size_t pos_, line_;
};

}  // namespace trilevel::io
