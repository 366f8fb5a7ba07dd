// trilevel_fuzz_replay FORMAT PATH...: runs the fuzz targets' checks (fuzz_reader.cpp) on files, or
// on every file of a directory, without libFuzzer, so that any compiler builds it. ctest replays the
// generated seeds and the regression inputs through it; it also replays a finding under gcc's ASan.
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <string>
#include <vector>

#include "fuzz_reader.hpp"

namespace fs = std::filesystem;

int main(int argc, char** argv) {
    if (argc < 3) {
        std::cerr << "usage: " << argv[0] << " vtk|vtu|bgeo|ply|xyz|mesh FILE|DIR...\n";
        return 2;
    }
    const std::string format = argv[1];
    if (format != "vtk" && format != "vtu" && format != "bgeo" && format != "ply" && format != "xyz" && format != "mesh") {
        std::cerr << argv[0] << ": unknown format '" << format << "'\n";
        return 2;
    }
    std::vector<fs::path> files;
    for (int i = 2; i < argc; ++i) {
        if (fs::is_directory(argv[i])) {
            for (const auto& e : fs::directory_iterator(argv[i])) files.push_back(e.path());
        } else if (fs::exists(argv[i])) {
            files.emplace_back(argv[i]);
        } else {
            std::cerr << argv[0] << ": no such file or directory: " << argv[i] << "\n";
            return 2;
        }
    }
    if (files.empty()) {
        std::cerr << argv[0] << ": no inputs\n";
        return 2;
    }
    for (const auto& f : files) {
        std::ifstream in(f, std::ios::binary);
        const std::string data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
        trilevel_fuzz_one(format, data);  // aborts on a finding
    }
    std::cout << files.size() << " inputs replayed through the " << format << " fuzz checks\n";
    return 0;
}
