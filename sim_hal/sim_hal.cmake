# springbok::sim_hal -- the Bullet backend of the HAL (double precision Bullet 3.24).
# Bullet stays behind a pimpl: only sim_hal's own sources see its headers (as
# SYSTEM headers, through the imported pkg-config target).
find_package(PkgConfig REQUIRED)
pkg_check_modules(BULLET REQUIRED IMPORTED_TARGET bullet-float64)

add_library(springbok_sim_hal STATIC
  "${CMAKE_CURRENT_LIST_DIR}/src/bullet_robot.cpp"
  "${CMAKE_CURRENT_LIST_DIR}/src/external_wrench.cpp"
  "${CMAKE_CURRENT_LIST_DIR}/src/principal_inertia.cpp")
add_library(springbok::sim_hal ALIAS springbok_sim_hal)
target_include_directories(springbok_sim_hal PUBLIC "${CMAKE_CURRENT_LIST_DIR}/include")
target_link_libraries(springbok_sim_hal
  PUBLIC springbok::options springbok::hal springbok::model Eigen3::Eigen
  PRIVATE PkgConfig::BULLET)
