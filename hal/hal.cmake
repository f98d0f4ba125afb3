add_library(springbok_hal INTERFACE)
add_library(springbok::hal ALIAS springbok_hal)
target_include_directories(springbok_hal INTERFACE "${CMAKE_CURRENT_LIST_DIR}/include")
target_link_libraries(springbok_hal INTERFACE springbok::model Eigen3::Eigen)

# The SocketCAN backend and drive codecs live in hal/can/ (own CMake file).
if(EXISTS "${CMAKE_CURRENT_LIST_DIR}/can/CMakeLists.txt")
  add_subdirectory("${CMAKE_CURRENT_LIST_DIR}/can" "${CMAKE_CURRENT_BINARY_DIR}/can")
endif()
