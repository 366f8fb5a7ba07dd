// Encodings the file generators of the tests and of the fuzz seed corpus (fuzz/make_corpus.cpp)
// need to build VTU and BGEO files by hand: base64, zlib, gzip. Failures throw std::runtime_error.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>

#include <zlib.h>

namespace trilevel::test {

inline std::string b64(const std::string& in) {
    static const char* t = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    for (std::size_t i = 0; i < in.size(); i += 3) {
        const std::uint32_t a = static_cast<unsigned char>(in[i]);
        const std::uint32_t b = i + 1 < in.size() ? static_cast<unsigned char>(in[i + 1]) : 0;
        const std::uint32_t c = i + 2 < in.size() ? static_cast<unsigned char>(in[i + 2]) : 0;
        const std::uint32_t w = (a << 16) | (b << 8) | c;
        out += t[w >> 18];
        out += t[(w >> 12) & 63];
        out += i + 1 < in.size() ? t[(w >> 6) & 63] : '=';
        out += i + 2 < in.size() ? t[w & 63] : '=';
    }
    return out;
}

/// A zlib stream (what VTU's vtkZLibDataCompressor writes per block).
inline std::string zcompress(const std::string& in) {
    uLongf len = compressBound(static_cast<uLong>(in.size()));
    std::string out(len, '\0');
    if (compress(reinterpret_cast<Bytef*>(out.data()), &len, reinterpret_cast<const Bytef*>(in.data()),
                 static_cast<uLong>(in.size())) != Z_OK)
        throw std::runtime_error("zlib compress failed");
    out.resize(len);
    return out;
}

/// A gzip member (what Partio writes for .bgeo.gz-style BGEO).
inline std::string gzip(const std::string& in) {
    z_stream zs{};
    if (deflateInit2(&zs, 6, Z_DEFLATED, 16 + MAX_WBITS, 8, Z_DEFAULT_STRATEGY) != Z_OK) throw std::runtime_error("gzip init failed");
    std::string out(deflateBound(&zs, static_cast<uLong>(in.size())) + 64, '\0');
    zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(in.data()));
    zs.avail_in = static_cast<uInt>(in.size());
    zs.next_out = reinterpret_cast<Bytef*>(out.data());
    zs.avail_out = static_cast<uInt>(out.size());
    const int rc = deflate(&zs, Z_FINISH);
    deflateEnd(&zs);
    if (rc != Z_STREAM_END) throw std::runtime_error("gzip failed");
    out.resize(zs.total_out);
    return out;
}

}  // namespace trilevel::test
