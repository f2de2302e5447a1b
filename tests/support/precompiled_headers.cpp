// The translation unit that builds the test programs' shared precompiled header (tests/CMakeLists.txt,
// lpstereo_test_precompiled_headers): GoogleTest, nlohmann JSON and the standard headers most tests
// include. It defines nothing; the test programs reuse the header it compiles.
