target_sources(fabrica_core PRIVATE ${CMAKE_CURRENT_LIST_DIR}/src/camera.cpp)
target_link_libraries(fabrica_core PUBLIC nlohmann_json::nlohmann_json)
